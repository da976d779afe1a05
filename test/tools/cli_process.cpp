#include "cli_process.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

namespace spool_vision
{
namespace test
{
CliRun runCommand(const std::string& command)
{
  CliRun run;
  char err_path[] = "/tmp/cli_stderr_XXXXXX";
  const int fd = mkstemp(err_path);
  if (fd < 0)
    return run;
  close(fd);
  FILE* pipe = popen((command + " 2>" + err_path).c_str(), "r");
  if (pipe)
  {
    std::string out;
    char buf[4096];
    while (size_t n = fread(buf, 1, sizeof(buf), pipe))
      out.append(buf, n);
    const int status = pclose(pipe);
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::istringstream lines(out);
    for (std::string line; std::getline(lines, line);)
      run.lines.push_back(line);
    std::ifstream err(err_path);
    run.errors.assign(std::istreambuf_iterator<char>(err), std::istreambuf_iterator<char>());
  }
  std::remove(err_path);
  return run;
}

}  // namespace test
}  // namespace spool_vision
