#include "spool_vision/focal_calibration.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

namespace spool_vision
{
namespace
{
std::vector<std::string> splitCsv(const std::string& line)
{
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ','))
  {
    const auto first = cell.find_first_not_of(" \t\r");
    const auto last = cell.find_last_not_of(" \t\r");
    cells.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
  }
  return cells;
}

bool endsWith(const std::string& text, const std::string& suffix)
{
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool parseNumber(const std::string& text, double& value)
{
  try
  {
    std::size_t used = 0;
    value = std::stod(text, &used);
    return used == text.size();
  }
  catch (const std::exception&)
  {
    return false;
  }
}

}  // namespace

std::vector<FocalSample> loadFocalSamplesCsv(const std::string& path)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error("cannot read " + path);
  std::vector<FocalSample> samples;
  int distance_col = -1;
  int diameter_col = -1;
  double unit = 0.0;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number)
  {
    const auto start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#')
      continue;
    const std::vector<std::string> cells = splitCsv(line);
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (distance_col < 0)
    {
      for (int c = 0; c < static_cast<int>(cells.size()); ++c)
      {
        const std::string& name = cells[c];
        if (name.find("distance") != std::string::npos)
        {
          distance_col = c;
          if (endsWith(name, "_mm"))
            unit = 0.001;
          else if (endsWith(name, "_cm"))
            unit = 0.01;
          else if (endsWith(name, "_m"))
            unit = 1.0;
        }
        else if (endsWith(name, "_px"))
          diameter_col = c;
      }
      if (distance_col < 0 || diameter_col < 0 || unit == 0.0)
        throw std::runtime_error(where +
                                 "expected a header with a distance column ending in "
                                 "_m, _cm or _mm and a diameter column ending in _px");
      continue;
    }
    FocalSample sample;
    if (static_cast<int>(cells.size()) <= std::max(distance_col, diameter_col) ||
        !parseNumber(cells[distance_col], sample.distance) || !parseNumber(cells[diameter_col], sample.diameter_px))
      throw std::runtime_error(where + "expected two numbers, got '" + line + "'");
    sample.distance *= unit;
    if (!(sample.distance > 0.0) || !(sample.diameter_px > 0.0))
      throw std::runtime_error(where + "distance and diameter must be positive");
    samples.push_back(sample);
  }
  if (samples.empty())
    throw std::runtime_error(path + ": no samples");
  return samples;
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
