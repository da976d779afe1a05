#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "spool_vision/focal_calibration.h"

namespace sv = spool_vision;

namespace
{
const std::string kAppendixB = std::string(SPOOL_TEST_DATA_DIR) + "/appendix_b_sensor_height.csv";

std::string writeTempCsv(const std::string& name, const std::string& text)
{
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}
}  // namespace

TEST(FocalCalibration, AppendixBGivesThesisCamera)
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

TEST(FocalCalibration, RecoversExactFocalFromSyntheticPairs)
{
  const double f = 812.25;
  const double flange = 0.35;
  std::vector<sv::FocalSample> samples;
  for (double d = 0.4; d <= 1.31; d += 0.05)
    samples.push_back({d, f * flange / d});
  const sv::FocalFit fit = sv::fitFocalLength(samples, flange, 480, 0.004);
  EXPECT_NEAR(fit.focal_px, f, 1e-9);
  EXPECT_NEAR(fit.sensor_height, 0.004 * 480 / f, 1e-15);
  EXPECT_LT(fit.rms_px, 1e-9);
  EXPECT_LT(fit.max_abs_px, 1e-9);
}

TEST(FocalCalibration, ResidualsAreObservedMinusPredicted)
{
  // Two samples whose D * OH straddle f * ROH: f = mean(D * OH) / ROH.
  const std::vector<sv::FocalSample> samples = {{1.0, 69.0}, {1.0, 71.0}};
  const sv::FocalFit fit = sv::fitFocalLength(samples, 0.35, 120, 0.004);
  EXPECT_NEAR(fit.focal_px, 200.0, 1e-9);
  EXPECT_NEAR(fit.residuals_px[0], -1.0, 1e-9);
  EXPECT_NEAR(fit.residuals_px[1], 1.0, 1e-9);
  EXPECT_NEAR(fit.rms_px, 1.0, 1e-9);
}

TEST(FocalCalibration, RejectsBadInput)
{
  EXPECT_THROW(sv::fitFocalLength({}), std::invalid_argument);
  EXPECT_THROW(sv::fitFocalLength({{0.0, 50.0}}), std::invalid_argument);
  EXPECT_THROW(sv::fitFocalLength({{1.0, 50.0}}, 0.35, 0), std::invalid_argument);
}

TEST(FocalCalibration, CsvUnitsAndErrors)
{
  const std::string mm = writeTempCsv("focal_mm.csv",
                                      "# comment\ndistance_mm, diameter_px\n"
                                      "1000, 70\n\n500 , 140\n");
  const std::vector<sv::FocalSample> samples = sv::loadFocalSamplesCsv(mm);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_DOUBLE_EQ(samples[0].distance, 1.0);
  EXPECT_DOUBLE_EQ(samples[1].distance, 0.5);
  EXPECT_DOUBLE_EQ(samples[1].diameter_px, 140.0);

  EXPECT_THROW(sv::loadFocalSamplesCsv(writeTempCsv("focal_nohead.csv", "1.0,70\n")), std::runtime_error);
  EXPECT_THROW(sv::loadFocalSamplesCsv(writeTempCsv("focal_bad.csv", "distance_m,d_px\n1.0,x\n")), std::runtime_error);
  EXPECT_THROW(sv::loadFocalSamplesCsv(writeTempCsv("focal_empty.csv", "distance_m,d_px\n")), std::runtime_error);
  EXPECT_THROW(sv::loadFocalSamplesCsv(::testing::TempDir() + "no_such_file.csv"), std::runtime_error);
}
