// Calibration CSV files: the tape-measured samples and image lists spool_calibrate reads
// (thesis Appendix B layout).
#pragma once

#include <string>
#include <vector>

#include "spool_vision/focal_calibration.h"

namespace spool_vision
{
/// Reads samples from a CSV: '#' comment lines, then a header naming a distance column (name
/// contains "distance", unit suffix _m, _cm or _mm) and a diameter column (suffix _px), then
/// one sample per line. Throws std::runtime_error naming the file and line.
std::vector<FocalSample> loadFocalSamplesCsv(const std::string& path);

/// One spool image taken at a tape-measured distance.
struct CalibrationImage
{
  std::string path;
  double distance = 0.0;  ///< m
};

/// Reads a list of calibration images: the same CSV layout with an `image` column instead of
/// the diameter (e.g. "image,distance_m"). Relative image paths are resolved against the CSV's
/// folder. Throws std::runtime_error naming the file and line.
std::vector<CalibrationImage> loadCalibrationImagesCsv(const std::string& path);

}  // namespace spool_vision
