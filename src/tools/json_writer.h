// A minimal JSON object writer for the tools' one-object-per-line output.
#pragma once

#include <string>

namespace spool_vision
{
class JsonObject
{
public:
  JsonObject& add(const std::string& key, const std::string& value);
  JsonObject& add(const std::string& key, const char* value)
  {
    return add(key, std::string(value));
  }
  JsonObject& add(const std::string& key, double value, int decimals = 4);
  JsonObject& add(const std::string& key, int value);
  JsonObject& add(const std::string& key, bool value);
  /// Inserts an already-rendered JSON value (an object, or "null").
  JsonObject& addRaw(const std::string& key, const std::string& json);
  std::string str() const
  {
    return "{" + body_ + "}";
  }

  static std::string quote(const std::string& s);

private:
  void key(const std::string& k);
  std::string body_;
};

}  // namespace spool_vision
