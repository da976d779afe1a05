#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <string>

#include <yaml-cpp/yaml.h>

#include "spool_vision/io/config_io.h"
#include "temp_file.h"

using spool_vision::DetectorParams;
using spool_vision::loadCameraInfoYaml;
using spool_vision::loadParamsYaml;
using spool_vision::ParamError;
using spool_vision::test::writeTemp;

namespace
{
const std::string kConfigDir = SPOOL_CONFIG_DIR;
}  // namespace

TEST(ConfigIo, DefaultYamlListsEveryKeyWithTheBuiltInValue)
{
  const YAML::Node root = YAML::LoadFile(kConfigDir + "/default.yaml");
  const DetectorParams defaults;
  for (const auto& spec : spool_vision::paramSpecs())
  {
    ASSERT_TRUE(root[spec.key]) << spec.key << " is missing from default.yaml";
    DetectorParams one;
    spool_vision::setParam(one, spec.key,
                           spec.type == spool_vision::ParamType::kChoice
                               ? spool_vision::ParamValue(root[spec.key].as<std::string>())
                               : spool_vision::ParamValue(root[spec.key].as<double>()));
    EXPECT_EQ(spool_vision::formatParamValue(spec.get(one)), spool_vision::formatParamValue(spec.get(defaults)))
        << spec.key;
  }
  EXPECT_EQ(root.size(), spool_vision::paramSpecs().size());
}

TEST(ConfigIo, DefaultYamlCommentsGiveTheTableUnitsAndChoices)
{
  // "key: value  # [unit] why", continued on indented comment lines: yaml-cpp drops comments,
  // so the lines are read as text.
  std::ifstream in(kConfigDir + "/default.yaml");
  std::map<std::string, std::string> comments;
  const std::regex key_line(R"(^([a-z0-9_]+):\s*\S+\s*#\s*(.*)$)");
  const std::regex continued(R"(^\s+#\s*(.*)$)");
  std::string key;
  std::smatch m;
  for (std::string line; std::getline(in, line);)
  {
    if (std::regex_match(line, m, key_line))
      comments[key = m[1]] = m[2];
    else if (!key.empty() && std::regex_match(line, m, continued))
      comments[key] += " " + m[1].str();
    else
      key.clear();
  }
  for (const auto& spec : spool_vision::paramSpecs())
  {
    SCOPED_TRACE(spec.key);
    ASSERT_EQ(comments.count(spec.key), 1u) << "no comment on the key's line";
    const std::string& comment = comments[spec.key];
    if (spec.type == spool_vision::ParamType::kChoice)
      for (const auto& choice : spec.choices)
        EXPECT_NE(comment.find(choice), std::string::npos) << "the comment should name '" << choice << "'";
    else
      EXPECT_EQ(comment.rfind("[" + (spec.unit.empty() ? std::string("-") : spec.unit) + "]", 0), 0u)
          << "the comment should start with the unit: " << comment;
  }
}

TEST(ConfigIo, ReadmeTableIsTheParamTable)
{
  // Each README row is the table's: key, default, unit, allowed values, meaning.
  std::ifstream in(kConfigDir + "/../README.md");
  const std::string readme((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(readme.empty());
  const DetectorParams defaults;
  for (const auto& spec : spool_vision::paramSpecs())
  {
    std::string allowed;
    if (spec.type == spool_vision::ParamType::kChoice)
      for (size_t i = 0; i < spec.choices.size(); ++i)
        allowed += (i ? "\\|" : "") + spec.choices[i];
    else
      allowed = "[" + spool_vision::formatParamValue(spec.min_value) + ", " +
                spool_vision::formatParamValue(spec.max_value) + "]";
    const std::string row = "| `" + spec.key + "` | " + spool_vision::formatParamValue(spec.get(defaults)) + " | " +
                            spec.unit + " | " + allowed + " | " + spec.doc + " |";
    EXPECT_NE(readme.find(row + "\n"), std::string::npos) << "README.md should list\n" << row;
  }
}

TEST(ConfigIo, SeedYamlIsTheThesisPipeline)
{
  DetectorParams p;
  loadParamsYaml(kConfigDir + "/seed.yaml", p);
  EXPECT_EQ(p.preprocess.binarize, spool_vision::BinarizeType::kFixed);
  EXPECT_DOUBLE_EQ(p.preprocess.binarize_threshold, 0.35);
  EXPECT_DOUBLE_EQ(p.preprocess.filter_sigma, 0.01);
  EXPECT_EQ(p.preprocess.morphology, spool_vision::MorphologyType::kOpen);
  EXPECT_EQ(p.preprocess.min_component_area, 30);
  EXPECT_DOUBLE_EQ(p.hough.sensitivity, 0.89);
  EXPECT_DOUBLE_EQ(p.hough.flange_radius_min, 35);
  EXPECT_DOUBLE_EQ(p.hough.flange_radius_max, 65);
  EXPECT_DOUBLE_EQ(p.hough.hole_radius_min, 3);
  EXPECT_DOUBLE_EQ(p.hough.hole_radius_max, 15);
  EXPECT_DOUBLE_EQ(p.matcher.concentric_tolerance, 0.01);
  EXPECT_EQ(p.geometry.yaw_mode, spool_vision::YawMode::kLinearFov);
  EXPECT_EQ(p.geometry.reference_mode, spool_vision::ReferenceMode::kFixed);
  EXPECT_DOUBLE_EQ(p.geometry.reference_x, 80);
  EXPECT_DOUBLE_EQ(p.geometry.reference_y, 50);
}

TEST(ConfigIo, BadFilesNameTheProblem)
{
  DetectorParams p;
  try
  {
    loadParamsYaml(writeTemp("unknown.yaml", "filter: gaussian\nsigmaa: 2\n"), p);
    FAIL() << "unknown key accepted";
  }
  catch (const ParamError& e)
  {
    EXPECT_EQ(e.key(), "sigmaa");
  }
  try
  {
    loadParamsYaml(writeTemp("range.yaml", "sensitivity: 1.2\n"), p);
    FAIL() << "out-of-range value accepted";
  }
  catch (const ParamError& e)
  {
    EXPECT_NE(std::string(e.what()).find("[0, 0.99]"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadParamsYaml(writeTemp("word.yaml", "filter_sigma: wide\n"), p), ParamError);
  EXPECT_THROW(loadParamsYaml(writeTemp("list.yaml", "filter_sigma: [1, 2]\n"), p), ParamError);
  EXPECT_THROW(loadParamsYaml(writeTemp("broken.yaml", "filter: [gaussian\n"), p), std::runtime_error);
  // A key that is a map or a list (YAML's "? " keys), found by params_yaml_fuzz: the file's error.
  for (const char* text : {"? {filter: gaussian}\n: 1\n", "? [filter]\n: 1\n", "? filter: median\n"})
  {
    const std::string path = writeTemp("complex_key.yaml", text);
    try
    {
      loadParamsYaml(path, p);
      FAIL() << "a complex key accepted: " << text;
    }
    catch (const ParamError& e)
    {
      FAIL() << "a complex key read as a parameter: " << e.what();
    }
    catch (const std::runtime_error& e)
    {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("not a parameter name"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(p.preprocess.filter, DetectorParams().preprocess.filter);
  EXPECT_THROW(loadParamsYaml("/nonexistent/params.yaml", p), std::runtime_error);
  // Relations are checked after the whole file is read, and a failed load changes nothing.
  EXPECT_THROW(loadParamsYaml(writeTemp("order.yaml", "hole_radius_min: 9\nhole_radius_max: 4\n"), p), ParamError);
  EXPECT_DOUBLE_EQ(p.hough.hole_radius_min, DetectorParams().hough.hole_radius_min);
}

TEST(ConfigIo, CameraInfoRoundTrip)
{
  spool_vision::CameraIntrinsics k;
  k.fx = 812.5;
  k.fy = 810.25;
  k.cx = 321.5;
  k.cy = 239.0;
  k.width = 640;
  k.height = 480;
  const std::string path = writeTemp("camera.yaml", spool_vision::cameraInfoToYaml(k, "c270"));
  const auto back = loadCameraInfoYaml(path);
  EXPECT_DOUBLE_EQ(back.fx, 812.5);
  EXPECT_DOUBLE_EQ(back.fy, 810.25);
  EXPECT_DOUBLE_EQ(back.cx, 321.5);
  EXPECT_DOUBLE_EQ(back.cy, 239.0);
  EXPECT_EQ(back.width, 640);
  EXPECT_EQ(back.height, 480);
  EXPECT_TRUE(back.distortion.empty());

  k.distortion = {-0.21, 0.04, 0.001, -0.002, 0.0};
  EXPECT_EQ(loadCameraInfoYaml(writeTemp("c270.yaml", spool_vision::cameraInfoToYaml(k, "c270"))).distortion,
            k.distortion);
  k.distortion = {-0.3, 0.1, 0.0, 0.0, 0.01, 0.02, -0.01, 0.003};
  EXPECT_EQ(loadCameraInfoYaml(writeTemp("rational.yaml", spool_vision::cameraInfoToYaml(k, "c270"))).distortion,
            k.distortion);
}

namespace
{
std::string calibration(const std::string& model, const std::string& d)
{
  return "image_width: 640\nimage_height: 480\n"
         "camera_matrix: {rows: 3, cols: 3, data: [800, 0, 320, 0, 801, 240, 0, 0, 1]}\n"
         "distortion_model: " +
         model + "\ndistortion_coefficients: {rows: 1, cols: 5, data: [" + d +
         "]}\n"
         "projection_matrix: {rows: 3, cols: 4, data: [760, 0, 318, 0, 0, 770, 236, 0, 0, 0, 1, 0]}\n";
}
}  // namespace

TEST(ConfigIo, CameraInfoIsKWithDistortionOrPWithout)
{
  // A raw camera: K and D (P describes the rectified image, not this one).
  const auto raw = loadCameraInfoYaml(writeTemp("raw.yaml", calibration("plumb_bob", "-0.2, 0.05, 0, 0, 0")));
  EXPECT_DOUBLE_EQ(raw.fx, 800.0);
  EXPECT_DOUBLE_EQ(raw.fy, 801.0);
  EXPECT_DOUBLE_EQ(raw.cx, 320.0);
  EXPECT_DOUBLE_EQ(raw.cy, 240.0);
  EXPECT_EQ(raw.distortion, (std::vector<double>{-0.2, 0.05, 0, 0, 0}));
  // No distortion: a rectified image, described by P.
  const auto rectified = loadCameraInfoYaml(writeTemp("rect.yaml", calibration("plumb_bob", "0, 0, 0, 0, 0")));
  EXPECT_DOUBLE_EQ(rectified.fx, 760.0);
  EXPECT_DOUBLE_EQ(rectified.fy, 770.0);
  EXPECT_DOUBLE_EQ(rectified.cx, 318.0);
  EXPECT_DOUBLE_EQ(rectified.cy, 236.0);
  EXPECT_FALSE(rectified.distorted());
  // A model the detector cannot undo is refused by name.
  try
  {
    loadCameraInfoYaml(writeTemp("fisheye.yaml", calibration("equidistant", "0.1, 0.01, 0, 0")));
    FAIL() << "equidistant accepted";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("equidistant"), std::string::npos) << e.what();
  }
}

TEST(ConfigIo, CameraInfoErrors)
{
  EXPECT_THROW(loadCameraInfoYaml(writeTemp("nok.yaml", "image_width: 640\n")), std::runtime_error);
  EXPECT_THROW(loadCameraInfoYaml(writeTemp("zero.yaml",
                                            "image_width: 640\nimage_height: 480\n"
                                            "camera_matrix: {rows: 3, cols: 3, data: [0,0,0,0,0,0,0,0,0]}\n")),
               std::runtime_error);
  // Found by camera_info_fuzz: a YAML infinity passed as the principal point.
  EXPECT_THROW(
      loadCameraInfoYaml(writeTemp("inf.yaml",
                                   "image_width: 640\nimage_height: 480\n"
                                   "camera_matrix: {rows: 3, cols: 3, data: [812, 0, +.INF, 0, 811, 243, 0, 0, 1]}\n")),
      std::runtime_error);
  EXPECT_THROW(loadCameraInfoYaml(writeTemp("short.yaml",
                                            "image_width: 640\nimage_height: 480\n"
                                            "camera_matrix: {rows: 3, cols: 3, data: [1, 2]}\n")),
               std::runtime_error);
}
