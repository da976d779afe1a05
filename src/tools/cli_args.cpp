#include "cli_args.h"

#include <cmath>
#include <cstdlib>
#include <iostream>

#include <CLI/CLI.hpp>

namespace spool_vision
{
namespace cli
{
CommandLine::CommandLine(int argc, char** argv, const std::set<std::string>& keys, const std::string& usage,
                         bool allow_positional, const std::set<std::string>& flags)
{
  // CLI11 splits the words (also --key=value); what it leaves over is judged here, so that the
  // messages name the word as before. The usage text is the tool's own.
  CLI::App app;
  app.set_help_flag();
  app.allow_extras();
  bool help = false;
  app.add_flag("-h,--help", help);
  std::map<std::string, CLI::Option*> options;
  for (const std::string& key : keys)
    options[key] = app.add_option(key)->expected(1)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  std::map<std::string, CLI::Option*> given_flags;
  for (const std::string& flag : flags)
    given_flags[flag] = app.add_flag(flag);
  try
  {
    app.parse(argc, argv);
  }
  catch (const CLI::ParseError& e)
  {
    // The one error CLI11 raises before the leftovers are judged: an option without its value.
    for (int i = 1; i < argc; ++i)
      if (keys.count(argv[i]) && i + 1 == argc)
        throw UsageError(std::string(argv[i]) + ": missing value");
    throw UsageError(e.what());
  }
  if (help)
  {
    std::cout << usage;
    std::exit(0);
  }
  for (const std::string& word : app.remaining())
  {
    if (word.size() > 1 && word[0] == '-')
      throw UsageError("unknown option '" + word + "'");
    if (!allow_positional)
      throw UsageError("unexpected argument '" + word + "'");
    positional_.push_back(word);
  }
  for (const auto& [key, option] : options)
    if (option->count() > 0)
      every_[key] = option->results();
  for (const auto& [flag, option] : given_flags)
    if (option->count() > 0)
      flags_.insert(flag);
}

std::string CommandLine::text(const std::string& key, const std::string& fallback) const
{
  const auto it = every_.find(key);
  return it == every_.end() ? fallback : it->second.back();
}

std::vector<std::string> CommandLine::every(const std::string& key) const
{
  const auto it = every_.find(key);
  return it == every_.end() ? std::vector<std::string>() : it->second;
}

std::optional<double> parseNumber(const std::string& text)
{
  std::size_t used = 0;
  double number = 0.0;
  try
  {
    number = std::stod(text, &used);
  }
  catch (const std::exception&)
  {
    return std::nullopt;
  }
  if (used == 0 || used != text.size() || !std::isfinite(number))
    return std::nullopt;
  return number;
}

double CommandLine::positiveNumber(const std::string& key, double fallback) const
{
  if (!every_.count(key))
    return fallback;
  const std::string value = text(key);
  const std::optional<double> number = parseNumber(value);
  if (!number || *number <= 0.0)
    throw UsageError(key + ": expected a positive number, got '" + value + "'");
  return *number;
}

int CommandLine::positiveInteger(const std::string& key, int max_value, int fallback) const
{
  const double number = positiveNumber(key, fallback);
  if (number != std::floor(number) || number > max_value)
    throw UsageError(key + ": expected an integer in [1, " + std::to_string(max_value) + "], got '" + text(key) + "'");
  return static_cast<int>(number);
}

int CommandLine::nonNegativeInteger(const std::string& key, int max_value, int fallback) const
{
  const std::uint64_t number = seed(key, static_cast<std::uint64_t>(fallback));
  if (number > static_cast<std::uint64_t>(max_value))
    throw UsageError(key + ": expected an integer in [0, " + std::to_string(max_value) + "], got '" + text(key) + "'");
  return static_cast<int>(number);
}

std::uint64_t CommandLine::seed(const std::string& key, std::uint64_t fallback) const
{
  if (!every_.count(key))
    return fallback;
  const std::string value = text(key);
  if (value.empty() || value.size() > 19 || value.find_first_not_of("0123456789") != std::string::npos)
    throw UsageError(key + ": expected a non-negative integer, got '" + value + "'");
  return std::stoull(value);
}

int runTool(const std::string& tool, const std::string& usage, const std::function<int()>& body)
{
  try
  {
    return body();
  }
  catch (const UsageError& e)
  {
    std::cerr << tool << ": " << e.what() << "\n" << (e.showUsage() ? usage : "");
    return 2;
  }
  catch (const std::exception& e)
  {
    std::cerr << tool << ": " << e.what() << "\n";
    return 1;
  }
}

}  // namespace cli
}  // namespace spool_vision
