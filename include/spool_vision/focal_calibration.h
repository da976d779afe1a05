// Focal length from spool images at known distances (thesis Eq. 3.2/3.3, Appendix B).
#pragma once

#include <vector>

namespace spool_vision
{
/// One observation: the flange seen `diameter_px` wide at a tape-measured `distance`.
struct FocalSample
{
  double distance = 0.0;     ///< m
  double diameter_px = 0.0;  ///< px
};

struct FocalFit
{
  double focal_px = 0.0;               ///< f in px, at the image height the diameters were measured in
  double sensor_height = 0.0;          ///< m, the thesis' SH = FL * FH / f (Eq. 3.3 with D * OH = f * ROH)
  double rms_px = 0.0;                 ///< RMS of the diameter residuals
  double max_abs_px = 0.0;             ///< largest diameter residual
  std::vector<double> residuals_px;    ///< observed - predicted diameter, per sample
  std::vector<double> sensor_heights;  ///< m, Eq. 3.3 per sample (the Appendix B column)
};

/// Least-squares fit of D * OH = f * ROH over the samples (one unknown, f): minimises the
/// residuals of D * OH, i.e. f = mean(D * OH) / ROH. `object_diameter` is ROH (m),
/// `image_height` is FH (px) and `lens_focal_length` FL (m) for the sensor height.
/// Throws std::invalid_argument without samples or on non-positive values.
FocalFit fitFocalLength(const std::vector<FocalSample>& samples, double object_diameter = 0.35, int image_height = 120,
                        double lens_focal_length = 0.004);

/// Fields of view (deg, horizontal) that bound the focal lengths a calibration may find.
constexpr double kWidestFieldOfView = 120.0;
constexpr double kNarrowestFieldOfView = 20.0;

/// Flange radius range (px) to search for in an image taken at `distance` (m) while the focal
/// length is still unknown: the radii of every camera `image_width` px wide whose horizontal
/// field of view lies between kNarrowestFieldOfView and kWidestFieldOfView.
void calibrationRadiusRange(double distance, double flange_diameter, int image_width, double& r_min, double& r_max);

}  // namespace spool_vision
