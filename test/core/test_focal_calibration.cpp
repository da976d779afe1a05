#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "spool_vision/focal_calibration.h"

namespace sv = spool_vision;

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

TEST(FocalCalibration, RadiusRangeCoversEveryPlausibleCamera)
{
  // 640 px wide: f from 185 px (120 deg) to 1815 px (20 deg); the thesis camera (800 px) and a
  // 77 deg webcam (400 px) lie inside, at any distance.
  for (double distance : {0.3, 0.8, 1.5})
  {
    double r_min = 0.0;
    double r_max = 0.0;
    sv::calibrationRadiusRange(distance, 0.35, 640, r_min, r_max);
    for (double f : {400.0, 800.0})
    {
      EXPECT_LT(r_min, f * 0.175 / distance);
      EXPECT_GT(r_max, f * 0.175 / distance);
    }
    EXPECT_NEAR(r_min, 320.0 / std::tan(60.0 * M_PI / 180.0) * 0.175 / distance, 1e-9);
    EXPECT_NEAR(r_max, 320.0 / std::tan(10.0 * M_PI / 180.0) * 0.175 / distance, 1e-9);
  }
}
