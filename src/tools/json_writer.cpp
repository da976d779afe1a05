#include "json_writer.h"

#include <cmath>
#include <cstdio>

namespace spool_vision
{
std::string JsonObject::quote(const std::string& s)
{
  std::string out = "\"";
  for (const char c : s)
  {
    switch (c)
    {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
        {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out += buf;
        }
        else
        {
          out += c;
        }
    }
  }
  return out + "\"";
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

JsonObject& JsonObject::addRaw(const std::string& k, const std::string& json)
{
  key(k);
  body_ += json;
  return *this;
}

}  // namespace spool_vision
