#include "json_writer.h"

#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

namespace spool_vision
{
std::string JsonObject::quote(const std::string& s)
{
  // nlohmann's escaping; bytes that are not UTF-8 (a file name can hold any) become U+FFFD.
  return nlohmann::json(s).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void JsonObject::key(const std::string& k)
{
  if (!body_.empty())
    body_ += ", ";
  body_ += quote(k) + ": ";
}

JsonObject& JsonObject::add(const std::string& k, const std::string& value)
{
  key(k);
  body_ += quote(value);
  return *this;
}

JsonObject& JsonObject::add(const std::string& k, double value, int decimals)
{
  key(k);
  if (!std::isfinite(value))
  {
    body_ += "null";  // JSON has no NaN: undefined numbers are null
    return *this;
  }
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, value);
  body_ += buf;
  return *this;
}

JsonObject& JsonObject::add(const std::string& k, int value)
{
  key(k);
  body_ += std::to_string(value);
  return *this;
}

JsonObject& JsonObject::add(const std::string& k, bool value)
{
  key(k);
  body_ += value ? "true" : "false";
  return *this;
}

JsonObject& JsonObject::addArray(const std::string& k, const std::vector<double>& values)
{
  key(k);
  body_ += "[";
  for (std::size_t i = 0; i < values.size(); ++i)
  {
    char buf[32] = "null";
    if (std::isfinite(values[i]))
      std::snprintf(buf, sizeof(buf), "%.6g", values[i]);
    body_ += (i ? ", " : "") + std::string(buf);
  }
  body_ += "]";
  return *this;
}

JsonObject& JsonObject::addRaw(const std::string& k, const std::string& json)
{
  key(k);
  body_ += json;
  return *this;
}

}  // namespace spool_vision
