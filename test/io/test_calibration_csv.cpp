#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "spool_vision/io/calibration_csv.h"
#include "temp_file.h"

namespace sv = spool_vision;
using spool_vision::test::writeTemp;

namespace
{
const std::string kAppendixB = std::string(SPOOL_TEST_DATA_DIR) + "/appendix_b_sensor_height.csv";
}  // namespace

TEST(CalibrationCsv, AppendixBGivesThesisCamera)
{
  const std::vector<sv::FocalSample> samples = sv::loadFocalSamplesCsv(kAppendixB);
  ASSERT_EQ(samples.size(), 24u);
  EXPECT_DOUBLE_EQ(samples.front().distance, 1.33);
  EXPECT_DOUBLE_EQ(samples.front().diameter_px, 53.09);

  const sv::FocalFit fit = sv::fitFocalLength(samples, 0.35, 120, 0.004);
  EXPECT_NEAR(fit.focal_px, 200.5, 0.5);
  EXPECT_NEAR(fit.sensor_height * 100.0, 0.24, 0.002);  // cm
  EXPECT_LT(fit.rms_px, 1.5);
  ASSERT_EQ(fit.residuals_px.size(), samples.size());
  ASSERT_EQ(fit.sensor_heights.size(), samples.size());
  // The thesis' per-row sensor heights lie in 0.23-0.25 cm.
  for (double sh : fit.sensor_heights)
  {
    EXPECT_GT(sh * 100.0, 0.23);
    EXPECT_LT(sh * 100.0, 0.25);
  }
}

TEST(CalibrationCsv, CsvUnitsAndErrors)
{
  const std::string mm = writeTemp("focal_mm.csv",
                                   "# comment\ndistance_mm, diameter_px\n"
                                   "1000, 70\n\n500 , 140\n");
  const std::vector<sv::FocalSample> samples = sv::loadFocalSamplesCsv(mm);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_DOUBLE_EQ(samples[0].distance, 1.0);
  EXPECT_DOUBLE_EQ(samples[1].distance, 0.5);
  EXPECT_DOUBLE_EQ(samples[1].diameter_px, 140.0);

  EXPECT_THROW(sv::loadFocalSamplesCsv(writeTemp("focal_nohead.csv", "1.0,70\n")), std::runtime_error);
  EXPECT_THROW(sv::loadFocalSamplesCsv(writeTemp("focal_bad.csv", "distance_m,d_px\n1.0,x\n")), std::runtime_error);
  EXPECT_THROW(sv::loadFocalSamplesCsv(writeTemp("focal_empty.csv", "distance_m,d_px\n")), std::runtime_error);
  EXPECT_THROW(sv::loadFocalSamplesCsv(::testing::TempDir() + "no_such_file.csv"), std::runtime_error);
}

TEST(CalibrationCsv, ImageListResolvesPathsAgainstItsFolder)
{
  const std::string list = writeTemp("focal_images.csv",
                                     "# spool images\nimage, distance_cm\n"
                                     "frames/a.png, 80\n/abs/b.png, 125.5\n");
  const std::vector<sv::CalibrationImage> images = sv::loadCalibrationImagesCsv(list);
  ASSERT_EQ(images.size(), 2u);
  EXPECT_EQ(images[0].path, ::testing::TempDir() + "frames/a.png");
  EXPECT_DOUBLE_EQ(images[0].distance, 0.8);
  EXPECT_EQ(images[1].path, "/abs/b.png");
  EXPECT_DOUBLE_EQ(images[1].distance, 1.255);

  EXPECT_THROW(sv::loadCalibrationImagesCsv(writeTemp("focal_images_nohead.csv", "a.png,0.8\n")), std::runtime_error);
  EXPECT_THROW(sv::loadCalibrationImagesCsv(writeTemp("focal_images_bad.csv", "image,distance_m\na.png,far\n")),
               std::runtime_error);
  EXPECT_THROW(sv::loadCalibrationImagesCsv(writeTemp("focal_images_neg.csv", "image,distance_m\na.png,-1\n")),
               std::runtime_error);
}
