// libFuzzer target: loadParamsYaml on arbitrary text. Documented errors: ParamError (a key, a
// type or a range) and std::runtime_error naming the file (unreadable, malformed, not a map).
// A yaml-cpp exception escaping unwrapped (it is a std::runtime_error too, but names neither the
// file nor the key), any other exception, a crash or a sanitizer report is a bug. On success
// the parameters must pass validateParams() and be kept; on failure `params` is unchanged.
#include <cstdlib>
#include <iostream>
#include <stdexcept>

#include <yaml-cpp/exceptions.h>

#include "spool_vision/io/config_io.h"
#include "yaml_file.h"

namespace sv = spool_vision;

namespace
{
void check(bool ok, const char* what)
{
  if (!ok)
  {
    std::cerr << "params_yaml_fuzz: " << what << "\n";
    std::abort();
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  const std::string& path = sv::fuzz::writeInput(data, size);
  const sv::DetectorParams defaults;
  sv::DetectorParams params;
  try
  {
    sv::loadParamsYaml(path, params);
    sv::validateParams(params);
  }
  catch (const sv::ParamError&)
  {
    check(sv::paramsToYaml(params) == sv::paramsToYaml(defaults), "a refused file changed the parameters");
  }
  catch (const YAML::Exception& e)
  {
    std::cerr << "unwrapped yaml-cpp exception: " << e.what() << "\n";
    check(false, "yaml-cpp exception escaped loadParamsYaml");
  }
  catch (const std::runtime_error& e)
  {
    check(std::string(e.what()).find(path) != std::string::npos, "a file error that does not name the file");
    check(sv::paramsToYaml(params) == sv::paramsToYaml(defaults), "a refused file changed the parameters");
  }
  return 0;
}
