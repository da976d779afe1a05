// Option values of the command-line tools, checked the same way in each.
#pragma once

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace spool_vision::cli
{
/// A bad command line: the tool prints the message and its usage and exits 2.
class UsageError : public std::runtime_error
{
  using std::runtime_error::runtime_error;
};

inline double parseNumber(const std::string& key, const std::string& text)
{
  std::size_t used = 0;
  double value = 0.0;
  try
  {
    value = std::stod(text, &used);
  }
  catch (const std::exception&)
  {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(value) || value <= 0.0)
    throw UsageError(key + ": expected a positive number, got '" + text + "'");
  return value;
}

inline int parseCount(const std::string& key, const std::string& text, int max_value)
{
  const double value = parseNumber(key, text);
  if (value != std::floor(value) || value > max_value)
    throw UsageError(key + ": expected an integer in [1, " + std::to_string(max_value) + "], got '" + text + "'");
  return static_cast<int>(value);
}

inline std::uint64_t parseSeed(const std::string& key, const std::string& text)
{
  if (text.empty() || text.size() > 19 || text.find_first_not_of("0123456789") != std::string::npos)
    throw UsageError(key + ": expected a non-negative integer, got '" + text + "'");
  return std::stoull(text);
}

}  // namespace spool_vision::cli
