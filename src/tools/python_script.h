// Runs one of the package's Python scripts (scripts/, matplotlib plots) with Debian's python3,
// the one catkin found: the pyenv shim on PATH has no matplotlib of the system's.
#pragma once

#include <string>
#include <vector>

namespace spool_vision
{
namespace cli
{
/// Runs scripts/`script` with `args` and waits. Throws std::runtime_error naming the script when
/// it cannot start or exits non-zero (the script says why on stderr).
void runPackageScript(const std::string& script, const std::vector<std::string>& args);

}  // namespace cli
}  // namespace spool_vision
