#include "spool_vision/io/config_io.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace spool_vision
{
namespace
{
YAML::Node loadFile(const std::string& path)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error("cannot open '" + path + "'");
  try
  {
    return YAML::Load(in);
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("'" + path + "' is not valid YAML: " + e.what());
  }
}

// A scalar as the value type the key expects, so "2" may set a double and 2.0 an int key
// (the range check then decides).
ParamValue scalarValue(const ParamSpec& spec, const YAML::Node& node)
{
  if (!node.IsScalar())
    throw ParamError(spec.key, "expected a single value; allowed: " + spec.allowed());
  if (spec.type == ParamType::kChoice)
    return node.as<std::string>();
  double number = 0.0;
  if (!YAML::convert<double>::decode(node, number))
    throw ParamError(spec.key, "'" + node.Scalar() + "' is not a number; allowed: " + spec.allowed());
  return number;
}
}  // namespace

void loadParamsYaml(const std::string& path, DetectorParams& params)
{
  const YAML::Node root = loadFile(path);
  if (root.IsNull())
    return;  // an empty file keeps the defaults
  if (!root.IsMap())
    throw std::runtime_error("'" + path + "' must be a map of parameter: value");
  DetectorParams loaded = params;
  for (const auto& item : root)
  {
    // YAML allows any node as a key ("? {a: b}"); a parameter's is a word.
    if (!item.first.IsScalar())
      throw std::runtime_error("'" + path + "': a key that is not a parameter name (line " +
                               std::to_string(item.first.Mark().line + 1) + ")");
    const std::string key = item.first.Scalar();
    const ParamSpec* spec = findParamSpec(key);
    if (!spec)
      throw ParamError(key, "unknown parameter in '" + path + "'");
    setParam(loaded, key, scalarValue(*spec, item.second));
  }
  validateParams(loaded);
  params = loaded;
}

std::string paramsToYaml(const DetectorParams& params)
{
  std::ostringstream os;
  for (const auto& spec : paramSpecs())
    os << spec.key << ": " << formatParamValue(spec.get(params)) << "  # " << spec.doc
       << (spec.unit.empty() ? "" : " [" + spec.unit + "]") << "; " << spec.allowed() << "\n";
  return os.str();
}

namespace
{
std::vector<double> matrixData(const YAML::Node& root, const char* key, std::size_t size)
{
  if (!root[key])
    return {};
  auto data = root[key]["data"].as<std::vector<double>>();
  if (data.size() != size)
    throw std::runtime_error(std::string(key) + ".data must have " + std::to_string(size) + " numbers, has " +
                             std::to_string(data.size()));
  return data;
}
}  // namespace

CameraIntrinsics loadCameraInfoYaml(const std::string& path)
{
  const YAML::Node root = loadFile(path);
  try
  {
    CameraIntrinsics k;
    k.width = root["image_width"].as<int>();
    k.height = root["image_height"].as<int>();
    const auto camera_matrix = matrixData(root, "camera_matrix", 9);
    if (camera_matrix.empty())
      throw std::runtime_error("camera_matrix is missing");
    const std::string model = root["distortion_model"] ? root["distortion_model"].as<std::string>() : "plumb_bob";
    std::vector<double> d;
    if (root["distortion_coefficients"])
      d = root["distortion_coefficients"]["data"].as<std::vector<double>>();
    if (model == "plumb_bob" ? d.size() > 5 : model == "rational_polynomial" ? d.size() > 8 : true)
      throw std::runtime_error("distortion_model '" + model + "' with " + std::to_string(d.size()) +
                               " coefficients is not supported (plumb_bob: 5, rational_polynomial: 8)");
    k.distortion = d;
    // As image_geometry reads a camera_info: a raw image is K with D; one without distortion
    // (rectified) is described by P, whose focal length may differ from K's.
    const auto projection = matrixData(root, "projection_matrix", 12);
    const auto& m = k.distorted() || projection.empty() ? camera_matrix : projection;
    const std::size_t row = k.distorted() || projection.empty() ? 3 : 4;
    k.fx = m[0];
    k.cx = m[2];
    k.fy = m[row + 1];
    k.cy = m[row + 2];
    if (!k.distorted())
      k.distortion.clear();
    if (!k.valid())
      throw std::runtime_error("uncalibrated: fx, fy and the image size must be positive");
    return k;
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("'" + path + "' is not a camera-calibration file (image_width, image_height, " +
                             "camera_matrix.data): " + e.what());
  }
  catch (const std::runtime_error& e)
  {
    throw std::runtime_error("'" + path + "': " + e.what());
  }
}

std::string cameraInfoToYaml(const CameraIntrinsics& k, const std::string& camera_name)
{
  std::ostringstream os;
  os.precision(10);
  os << "image_width: " << k.width << "\n"
     << "image_height: " << k.height << "\n"
     << "camera_name: " << camera_name << "\n"
     << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [" << k.fx << ", 0, " << k.cx << ", 0, " << k.fy << ", " << k.cy
     << ", 0, 0, 1]\n"
     << "distortion_model: " << (k.distortion.size() > 5 ? "rational_polynomial" : "plumb_bob") << "\n";
  std::vector<double> d = k.distortion;
  d.resize(d.size() > 5 ? 8 : 5, 0.0);
  os << "distortion_coefficients:\n  rows: 1\n  cols: " << d.size() << "\n  data: [";
  for (std::size_t i = 0; i < d.size(); ++i)
    os << (i ? ", " : "") << d[i];
  os << "]\n"
     << "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
     << "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [" << k.fx << ", 0, " << k.cx << ", 0, 0, " << k.fy << ", "
     << k.cy << ", 0, 0, 0, 1, 0]\n";
  return os.str();
}

void saveCameraInfoYaml(const std::string& path, const CameraIntrinsics& camera, const std::string& camera_name)
{
  std::ofstream out(path);
  out << cameraInfoToYaml(camera, camera_name);
  if (!out)
    throw std::runtime_error("cannot write " + path);
}

}  // namespace spool_vision
