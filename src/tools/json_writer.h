// spool_detect's one-object-per-line output: `"key": value` pairs joined by ", ", numbers with a
// fixed number of decimals (the format its users and tests read); strings escaped by nlohmann-json.
#pragma once

#include <string>
#include <vector>

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
  /// A JSON array of numbers in 6 significant digits (covariances span orders of magnitude); a
  /// value that is not finite is null.
  JsonObject& addArray(const std::string& key, const std::vector<double>& values);
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
