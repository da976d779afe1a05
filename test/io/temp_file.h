// Small files the io tests write and then read back.
#pragma once

#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace spool_vision
{
namespace test
{
/// Writes `text` to `name` in gtest's temporary folder; returns the path.
inline std::string writeTemp(const std::string& name, const std::string& text)
{
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}
}  // namespace test
}  // namespace spool_vision
