// The fuzz input as a file the YAML loaders can open: one file per process, rewritten for
// every input (the loaders read a path; a temporary file keeps them unchanged).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <unistd.h>

namespace spool_vision::fuzz
{
inline const std::string& writeInput(const std::uint8_t* data, std::size_t size)
{
  static const std::string path = []
  {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/spool_vision_fuzz_" + std::to_string(getpid()) + ".yaml";
  }();
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file || std::fwrite(data, 1, size, file) != size || std::fclose(file) != 0)
  {
    std::perror(path.c_str());
    std::abort();
  }
  return path;
}
}  // namespace spool_vision::fuzz
