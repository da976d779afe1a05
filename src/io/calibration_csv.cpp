#include "spool_vision/io/calibration_csv.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

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

// One data line of a calibration CSV: the distance in metres and the cell of the other column.
struct DistanceRow
{
  double distance;
  std::string value;
  std::string where;  // "path:line: " for messages
};

// Reads '#' comment lines, then a header naming a distance column (name contains "distance",
// unit suffix _m, _cm or _mm) and a value column (`is_value_column`, described to the user as
// `value_column`), then one row per line with a positive distance and a non-empty value.
std::vector<DistanceRow> readDistanceCsv(const std::string& path,
                                         const std::function<bool(const std::string&)>& is_value_column,
                                         const std::string& value_column)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error("cannot read " + path);
  std::vector<DistanceRow> rows;
  std::vector<std::string> header;
  int distance_col = -1;
  int value_col = -1;
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
        else if (is_value_column(name))
          value_col = c;
      }
      if (distance_col < 0 || value_col < 0 || unit == 0.0)
        throw std::runtime_error(where + "expected a header with a distance column ending in _m, _cm or _mm and " +
                                 value_column);
      header = cells;
      continue;
    }
    DistanceRow row{0.0, "", where};
    if (static_cast<int>(cells.size()) <= std::max(distance_col, value_col) ||
        !parseNumber(cells[distance_col], row.distance) || cells[value_col].empty())
      throw std::runtime_error(where + "expected a number under '" + header[distance_col] + "' and a value under '" +
                               header[value_col] + "', got '" + line + "'");
    row.distance *= unit;
    if (!(row.distance > 0.0))
      throw std::runtime_error(where + "the distance must be positive");
    row.value = cells[value_col];
    rows.push_back(row);
  }
  if (rows.empty())
    throw std::runtime_error(path + ": no samples");
  return rows;
}

}  // namespace

std::vector<FocalSample> loadFocalSamplesCsv(const std::string& path)
{
  std::vector<FocalSample> samples;
  for (const DistanceRow& row : readDistanceCsv(
           path, [](const std::string& name) { return endsWith(name, "_px"); }, "a diameter column ending in _px"))
  {
    FocalSample sample{row.distance, 0.0};
    if (!parseNumber(row.value, sample.diameter_px) || !(sample.diameter_px > 0.0))
      throw std::runtime_error(row.where + "the diameter must be a positive number, got '" + row.value + "'");
    samples.push_back(sample);
  }
  return samples;
}

std::vector<CalibrationImage> loadCalibrationImagesCsv(const std::string& path)
{
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::vector<CalibrationImage> images;
  for (const DistanceRow& row : readDistanceCsv(
           path, [](const std::string& name) { return name == "image"; }, "an 'image' column"))
    images.push_back({(folder / row.value).string(), row.distance});
  return images;
}

}  // namespace spool_vision
