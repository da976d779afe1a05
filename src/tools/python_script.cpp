#include "python_script.h"

#include <spawn.h>
#include <sys/wait.h>

#include <stdexcept>

extern char** environ;

namespace spool_vision
{
namespace cli
{
void runPackageScript(const std::string& script, const std::vector<std::string>& args)
{
  std::vector<std::string> words = {SPOOL_VISION_PYTHON, SPOOL_VISION_SOURCE_DIR "/scripts/" + script};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& w : words)
    argv.push_back(w.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  int status = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0 || waitpid(pid, &status, 0) != pid)
    throw std::runtime_error("cannot run " + words[0] + " " + words[1]);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error(words[1] + " failed");
}

}  // namespace cli
}  // namespace spool_vision
