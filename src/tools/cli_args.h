// Command-line handling shared by the tools, the words split by CLI11: `--key value` (or
// `--key=value`) options, positional arguments, value checks whose messages name the option, and
// the exit codes (0 ok, 1 failed, 2 bad command line).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace spool_vision
{
namespace cli
{
/// A bad command line or configuration: the tool exits 2. The usage text is printed with it
/// unless `show_usage` is false (a bad value inside a file, where the usage does not help).
class UsageError : public std::runtime_error
{
public:
  explicit UsageError(const std::string& what, bool show_usage = true)
    : std::runtime_error(what), show_usage_(show_usage)
  {
  }
  bool showUsage() const
  {
    return show_usage_;
  }

private:
  bool show_usage_;
};

/// The whole of `text` as a finite number (std::stod), or nullopt.
std::optional<double> parseNumber(const std::string& text);

/// argv split into `--key value` options and positional arguments.
class CommandLine
{
public:
  /// Each of `keys` takes one value (the last one given counts); "--help" or "-h" prints
  /// `usage` on stdout and exits 0; any other word starting with '-' (but "-" alone) is an
  /// unknown option. Throws UsageError naming the option, and on positional arguments unless
  /// `allow_positional`. Each of `flags` stands alone, without a value.
  CommandLine(int argc, char** argv, const std::set<std::string>& keys, const std::string& usage,
              bool allow_positional = false, const std::set<std::string>& flags = {});

  /// Whether the flag was given.
  bool has(const std::string& flag) const
  {
    return flags_.count(flag) > 0;
  }

  /// The option's value, `fallback` when it was not given.
  std::string text(const std::string& key, const std::string& fallback = "") const;
  /// Every value the option was given, in order (empty when it was not given).
  std::vector<std::string> every(const std::string& key) const;
  /// The option as a finite number > 0, `fallback` when it was not given.
  double positiveNumber(const std::string& key, double fallback) const;
  /// The option as an integer in [1, max_value], `fallback` when it was not given.
  int positiveInteger(const std::string& key, int max_value, int fallback) const;
  /// The option as an integer in [0, max_value], `fallback` when it was not given.
  int nonNegativeInteger(const std::string& key, int max_value, int fallback) const;
  /// The option as a non-negative integer (a random seed), `fallback` when it was not given.
  std::uint64_t seed(const std::string& key, std::uint64_t fallback) const;

  const std::vector<std::string>& positional() const
  {
    return positional_;
  }

private:
  std::map<std::string, std::vector<std::string>> every_;  ///< each option's values, in order
  std::vector<std::string> positional_;
  std::set<std::string> flags_;
};

/// A tool's main: runs `body` and returns its exit code. A UsageError prints "tool: what" (and
/// the usage) on stderr and gives 2; any other exception prints "tool: what" and gives 1.
int runTool(const std::string& tool, const std::string& usage, const std::function<int()>& body);

}  // namespace cli
}  // namespace spool_vision
