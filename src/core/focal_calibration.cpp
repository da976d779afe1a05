#include "spool_vision/focal_calibration.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace spool_vision
{
void calibrationRadiusRange(double distance, double flange_diameter, int image_width, double& r_min, double& r_max)
{
  // A pinhole camera with horizontal field of view a has f = (w / 2) / tan(a / 2).
  constexpr double kDeg = M_PI / 180.0;
  const double half_width = 0.5 * image_width;
  r_min = half_width / std::tan(0.5 * kWidestFieldOfView * kDeg) * 0.5 * flange_diameter / distance;
  r_max = half_width / std::tan(0.5 * kNarrowestFieldOfView * kDeg) * 0.5 * flange_diameter / distance;
}

FocalFit fitFocalLength(const std::vector<FocalSample>& samples, double object_diameter, int image_height,
                        double lens_focal_length)
{
  if (samples.empty())
    throw std::invalid_argument("focal calibration: no samples");
  if (!(object_diameter > 0.0) || image_height <= 0 || !(lens_focal_length > 0.0))
    throw std::invalid_argument(
        "focal calibration: object diameter, image height and lens "
        "focal length must be positive");
  const Eigen::Index n = static_cast<Eigen::Index>(samples.size());
  Eigen::VectorXd lhs(n);  // D * OH
  for (Eigen::Index i = 0; i < n; ++i)
  {
    const FocalSample& s = samples[static_cast<std::size_t>(i)];
    if (!(s.distance > 0.0) || !(s.diameter_px > 0.0))
      throw std::invalid_argument("focal calibration: distances and diameters must be positive");
    lhs(i) = s.distance * s.diameter_px;
  }
  // Design matrix of the one-parameter model D * OH = f * ROH.
  const Eigen::VectorXd design = Eigen::VectorXd::Constant(n, object_diameter);
  FocalFit fit;
  fit.focal_px = design.dot(lhs) / design.squaredNorm();
  fit.sensor_height = lens_focal_length * image_height / fit.focal_px;

  double sum2 = 0.0;
  for (const FocalSample& s : samples)
  {
    const double residual = s.diameter_px - fit.focal_px * object_diameter / s.distance;
    fit.residuals_px.push_back(residual);
    fit.sensor_heights.push_back(lens_focal_length * object_diameter * image_height / (s.distance * s.diameter_px));
    sum2 += residual * residual;
    fit.max_abs_px = std::max(fit.max_abs_px, std::abs(residual));
  }
  fit.rms_px = std::sqrt(sum2 / samples.size());
  return fit;
}

}  // namespace spool_vision
