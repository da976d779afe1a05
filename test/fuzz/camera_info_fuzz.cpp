// libFuzzer target: loadCameraInfoYaml on arbitrary text. Documented error: std::runtime_error
// naming the file. A yaml-cpp exception escaping unwrapped, any other exception, a crash or a
// sanitizer report is a bug; what it returns must be a valid camera of finite numbers.
#include <cmath>
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
    std::cerr << "camera_info_fuzz: " << what << "\n";
    std::abort();
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  const std::string& path = sv::fuzz::writeInput(data, size);
  try
  {
    const sv::CameraIntrinsics camera = sv::loadCameraInfoYaml(path);
    check(camera.valid(), "loaded an invalid camera");
    bool finite =
        std::isfinite(camera.fx) && std::isfinite(camera.fy) && std::isfinite(camera.cx) && std::isfinite(camera.cy);
    for (const double d : camera.distortion)
      finite = finite && std::isfinite(d);
    check(finite, "loaded a camera with a non-finite number");
  }
  catch (const YAML::Exception& e)
  {
    std::cerr << "unwrapped yaml-cpp exception: " << e.what() << "\n";
    check(false, "yaml-cpp exception escaped loadCameraInfoYaml");
  }
  catch (const std::runtime_error& e)
  {
    check(std::string(e.what()).find(path) != std::string::npos, "an error that does not name the file");
  }
  return 0;
}
