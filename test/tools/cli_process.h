// Runs a command-line tool the way a user does, for the CLI tests: a process, its output and
// its exit code.
#pragma once

#include <string>
#include <vector>

namespace spool_vision
{
namespace test
{
struct CliRun
{
  int exit_code = -1;              ///< -1 when the process did not exit normally
  std::vector<std::string> lines;  ///< stdout, one entry per line
  std::string errors;              ///< stderr, whole
};

/// Runs `command` through the shell.
CliRun runCommand(const std::string& command);

}  // namespace test
}  // namespace spool_vision
