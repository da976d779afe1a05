// spool_calibrate, spool_render, spool_eval, spool_sim and scripts/plot_charts.py checked as a user runs
// them: a process, its output, its exit code and the files it writes. The calibration images come
// from the renderer, so the focal length they were taken with is known exactly.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_process.h"
#include "spool_vision/io/config_io.h"
#include "spool_vision/render/spool_renderer.h"

namespace fs = std::filesystem;
namespace sv = spool_vision;
using sv::test::CliRun;

namespace
{
const std::string kAppendixB = std::string(SPOOL_TEST_DATA_DIR) + "/appendix_b_sensor_height.csv";

CliRun spoolCalibrate(const std::string& args)
{
  return sv::test::runCommand(std::string(SPOOL_CALIBRATE_BIN) + " " + args);
}

CliRun spoolRender(const std::string& args)
{
  return sv::test::runCommand(std::string(SPOOL_RENDER_BIN) + " " + args);
}

CliRun spoolEval(const std::string& args)
{
  return sv::test::runCommand(std::string(SPOOL_EVAL_BIN) + " " + args);
}

CliRun spoolSim(const std::string& args)
{
  return sv::test::runCommand(std::string(SPOOL_SIM_BIN) + " " + args);
}

CliRun plotCharts(const std::string& args)
{
  return sv::test::runCommand(std::string(SPOOL_PYTHON) + " " + SPOOL_PLOT_CHARTS + " " + args);
}

bool has(const std::string& text, const std::string& fragment)
{
  return text.find(fragment) != std::string::npos;
}

// The number after "focal length: " in spool_calibrate's report, NaN without one.
double reportedFocal(const CliRun& run)
{
  for (const std::string& line : run.lines)
    if (line.rfind("focal length: ", 0) == 0)
      return std::strtod(line.c_str() + 14, nullptr);
  return std::nan("");
}

fs::path freshDir(const std::string& name)
{
  const fs::path dir = fs::path(::testing::TempDir()) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Renders the spool at 60-130 cm on random shelves (neighbours, labels, noise, JPEG) with a
// camera of focal length `focal`, and lists the frames with their distances in dir/list.csv
// (relative paths). `extra_rows` are appended to the list as they are.
fs::path renderCalibrationSet(const fs::path& dir, int width, int height, double focal,
                              const std::string& extra_rows = "")
{
  sv::CameraIntrinsics camera = sv::CameraIntrinsics::thesisDefault(width, height);
  camera.fx = camera.fy = focal;
  const sv::SpoolRenderer renderer(camera);
  fs::create_directories(dir / "frames");
  std::ofstream list(dir / "list.csv");
  list << "# spool images at tape-measured distances\nimage,distance_m\n";
  for (int i = 0; i < 8; ++i)
  {
    sv::CameraPose pose;
    pose.distance = 0.6 + 0.1 * i;
    const sv::RenderedFrame frame = renderer.render(sv::randomScene(sv::SceneKind::kSpool, 100 + i), pose);
    const std::string name = "frames/d" + std::to_string(i) + ".png";
    cv::imwrite((dir / name).string(), frame.image);
    list << name << "," << frame.truth.distance << "\n";
  }
  list << extra_rows;
  return dir / "list.csv";
}

struct CalibrationCase
{
  int width;
  int height;
  double focal;
};

class SpoolCalibrateImages : public ::testing::TestWithParam<CalibrationCase>
{
};
}  // namespace

TEST_P(SpoolCalibrateImages, FitsTheFocalLengthTheImagesWereRenderedWith)
{
  const CalibrationCase c = GetParam();
  const fs::path dir =
      freshDir("calibrate_" + std::to_string(c.width) + "_" + std::to_string(static_cast<int>(c.focal)));
  // An image without a spool and a missing one are reported and skipped.
  cv::imwrite((dir / "blank.png").string(), cv::Mat(c.height, c.width, CV_8UC3, cv::Scalar::all(128)));
  const fs::path list = renderCalibrationSet(dir, c.width, c.height, c.focal, "blank.png,0.8\nmissing.png,0.9\n");
  const fs::path yaml = dir / "camera.yaml";

  const CliRun run = spoolCalibrate("--images " + list.string() + " --out " + yaml.string());
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  EXPECT_NEAR(reportedFocal(run), c.focal, 0.01 * c.focal);
  EXPECT_TRUE(has(run.errors, "blank.png: no flange found")) << run.errors;
  EXPECT_TRUE(has(run.errors, "missing.png: no such file")) << run.errors;
  EXPECT_TRUE(std::find(run.lines.begin(), run.lines.end(), "samples: 8") != run.lines.end());

  const sv::CameraIntrinsics camera = sv::loadCameraInfoYaml(yaml.string());
  EXPECT_EQ(camera.width, c.width);
  EXPECT_EQ(camera.height, c.height);
  EXPECT_NEAR(camera.fx, c.focal, 0.01 * c.focal);
  EXPECT_DOUBLE_EQ(camera.fy, camera.fx);
  EXPECT_DOUBLE_EQ(camera.cx, (c.width - 1) / 2.0);
  EXPECT_DOUBLE_EQ(camera.cy, (c.height - 1) / 2.0);
}

// The thesis camera at VGA and at the thesis' own 160x120, and a wide-angle webcam (77 deg) whose
// flanges lie outside the radius range the detector would derive from its fallback camera.
INSTANTIATE_TEST_SUITE_P(Cameras, SpoolCalibrateImages,
                         ::testing::Values(CalibrationCase{640, 480, 800.0}, CalibrationCase{160, 120, 200.0},
                                           CalibrationCase{640, 480, 400.0}));

TEST(SpoolCalibrateCli, FewerThanTwoFlangesIsAnError)
{
  const fs::path dir = freshDir("calibrate_too_few");
  cv::imwrite((dir / "blank.png").string(), cv::Mat(120, 160, CV_8UC3, cv::Scalar::all(128)));
  std::ofstream(dir / "list.csv") << "image,distance_cm\nblank.png,80\nmissing.png,90\n";
  const CliRun run = spoolCalibrate("--images " + (dir / "list.csv").string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(has(run.errors, "found in 0 of 2 images; the fit needs at least 2")) << run.errors;
}

TEST(SpoolCalibrateCli, AppendixBCsvGivesTheThesisCamera)
{
  const fs::path yaml = freshDir("calibrate_csv") / "camera.yaml";
  const CliRun run = spoolCalibrate("--csv " + kAppendixB + " --width 160 --height 120 --out " + yaml.string());
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  EXPECT_NEAR(reportedFocal(run), 200.5, 0.5);
  const sv::CameraIntrinsics camera = sv::loadCameraInfoYaml(yaml.string());
  EXPECT_EQ(camera.height, 120);
  EXPECT_NEAR(camera.fx, 200.5, 0.5);
}

TEST(SpoolCalibrateCli, BadOptionsExitTwoNamingTheOption)
{
  const fs::path dir = freshDir("calibrate_bad");
  std::ofstream(dir / "bad.yaml") << "sensitivity: 3\n";
  struct Case
  {
    std::string args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"--frobnicate 1", "unknown option '--frobnicate'"},
      {"", "give either --csv or --images"},
      {"--csv a.csv --images b.csv", "give either --csv or --images"},
      {"--csv " + kAppendixB, "--width and --height are required"},
      {"--csv " + kAppendixB + " --width 160 --height x", "--height: expected a positive number, got 'x'"},
      {"--images list.csv --width 160", "--width/--height go with --csv"},
      {"--csv " + kAppendixB + " --width 160 --height 120 --flange-diameter", "--flange-diameter: missing value"},
      {"--images list.csv --config " + (dir / "bad.yaml").string(), "parameter 'sensitivity'"},
      {"--csv " + kAppendixB + " stray", "unexpected argument 'stray'"},
  };
  for (const Case& c : cases)
  {
    const CliRun run = spoolCalibrate(c.args);
    EXPECT_EQ(run.exit_code, 2) << c.args;
    EXPECT_TRUE(has(run.errors, "spool_calibrate: " + c.message)) << c.args << "\n" << run.errors;
  }
}

TEST(SpoolCalibrateCli, MissingFilesAreClearErrors)
{
  const std::string missing = ::testing::TempDir() + "no_such_list.csv";
  for (const std::string& option : {"--images " + missing, "--csv " + missing + " --width 160 --height 120"})
  {
    const CliRun run = spoolCalibrate(option);
    EXPECT_EQ(run.exit_code, 1) << option;
    EXPECT_TRUE(has(run.errors, "spool_calibrate: cannot read " + missing)) << run.errors;
  }
}

TEST(SpoolRenderCli, WritesFramesTruthAndCameraInfo)
{
  const fs::path dir = freshDir("render_cli") / "out";
  const CliRun run = spoolRender("--out " + dir.string() + " --width 64 --height 48 --count 2 --set approach");
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  for (const char* name : {"frame_00000.png", "frame_00000.json", "frame_00001.png", "frame_00001.json"})
    EXPECT_TRUE(fs::exists(dir / name)) << name;
  const sv::CameraIntrinsics camera = sv::loadCameraInfoYaml((dir / "camera_info.yaml").string());
  EXPECT_EQ(camera.width, 64);
  EXPECT_DOUBLE_EQ(camera.fx, 200.0 * 48 / 120.0);  // the thesis camera without --focal
}

TEST(SpoolRenderCli, DistortedSetAndLensOption)
{
  const fs::path root = freshDir("render_cli_lens");
  // The distorted set's lens by default; --distortion replaces it, for any set.
  const CliRun set =
      spoolRender("--out " + (root / "set").string() + " --width 64 --height 48 --count 1 --set distorted");
  ASSERT_EQ(set.exit_code, 0) << set.errors;
  const CliRun lens = spoolRender("--out " + (root / "lens").string() +
                                  " --width 64 --height 48 --count 1 --distortion -0.1,0.02,0,0,0,0.01,0,0");
  ASSERT_EQ(lens.exit_code, 0) << lens.errors;
  auto json = [](const fs::path& path) { return nlohmann::json::parse(std::ifstream(path)); };
  const nlohmann::json truth = json(root / "set" / "frame_00000.json");
  EXPECT_EQ(truth["camera"]["distortion"], nlohmann::json({-0.2, 0.05, 0.001, -0.0005, 0.0}));
  EXPECT_EQ(truth["set"], "distorted");
  EXPECT_EQ(truth["image"], "frame_00000.png");
  EXPECT_EQ(json(root / "lens" / "frame_00000.json")["camera"]["distortion"],
            nlohmann::json({-0.1, 0.02, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0}));
  EXPECT_TRUE(fs::exists(root / "lens" / "frame_00000.png"));
}

TEST(SpoolRenderCli, BadOptionsExitTwoNamingTheOption)
{
  const std::string out = "--out " + ::testing::TempDir() + "render_bad";
  struct Case
  {
    std::string args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {out + " --width 64 --height 48 --frobnicate", "unknown option '--frobnicate'"},
      {"--width 64 --height 48", "--out is required"},
      {out + " --width 0 --height 48", "--width: expected a positive number, got '0'"},
      {out + " --width 64 --height 48 --count 1.5", "--count: expected an integer in [1, 1000000], got '1.5'"},
      {out + " --width 64 --height 48 --set all",
       "--set: expected main, approach, negatives, hard, distorted, approach_hard, oblique, packed or packed_oblique, "
       "got 'all'"},
      {out + " --width 64 --height 48 --distortion -0.2,0.05,0", "--distortion: expected 4, 5 (plumb_bob) or 8"},
      {out + " --width 64 --height 48 --distortion -0.2,x,0,0", "--distortion: 'x' is not a number"},
      {out + " --width 64 --height 48 --seed -1", "--seed: expected a non-negative integer, got '-1'"},
      {out + " --width 16 --height 48", "--width/--height: at least 32 px"},
  };
  for (const Case& c : cases)
  {
    const CliRun run = spoolRender(c.args);
    EXPECT_EQ(run.exit_code, 2) << c.args;
    EXPECT_TRUE(has(run.errors, "spool_render: " + c.message)) << c.args << "\n" << run.errors;
  }
}

TEST(SpoolRenderCli, UnwritableOutputIsAClearError)
{
  const fs::path file = freshDir("render_unwritable") / "a_file";
  std::ofstream(file) << "not a folder";
  const CliRun run = spoolRender("--out " + (file / "out").string() + " --width 64 --height 48 --count 1");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(has(run.errors, "spool_render: ")) << run.errors;
  EXPECT_TRUE(has(run.errors, (file / "out").string())) << run.errors;
}

// A chart PNG as the report shows it: 900x540 and not blank.
void expectDrawnChart(const fs::path& png)
{
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(image.empty()) << png;
  EXPECT_EQ(image.size(), cv::Size(900, 540)) << png;
  double low = 0.0;
  double high = 0.0;
  cv::minMaxLoc(image, &low, &high);
  EXPECT_GT(high - low, 100.0) << png;
}

TEST(PlotChartsCli, DrawsLineAndBarChartsWithGaps)
{
  const fs::path dir = freshDir("plot_charts");
  std::ofstream(dir / "charts.json") << R"({"charts": [
    {"file": "line.png", "kind": "line", "title": "t", "x_label": "x", "y_label": "y",
     "series": [{"label": "a", "x": [1, 2, 3], "y": [0.5, null, 1.5], "line": true},
                {"label": "b", "x": [1, 2], "y": [1, 2], "line": false}],
     "levels": [{"label": "+1%", "y": 1.0}]},
    {"file": "bar.png", "kind": "bar", "title": "t", "y_label": "%", "y_max": 100,
     "categories": ["p", "q"], "groups": [{"label": "g", "values": [40, null]}]}]})";
  const CliRun run = plotCharts((dir / "charts.json").string());
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  expectDrawnChart(dir / "line.png");
  expectDrawnChart(dir / "bar.png");
  // Into another folder, made when missing.
  const CliRun elsewhere = plotCharts((dir / "charts.json").string() + " " + (dir / "out" / "charts").string());
  ASSERT_EQ(elsewhere.exit_code, 0) << elsewhere.errors;
  expectDrawnChart(dir / "out" / "charts" / "bar.png");
}

TEST(PlotChartsCli, BadChartsFilesExitTwoNamingTheChartAndKey)
{
  const fs::path dir = freshDir("plot_charts_bad");
  struct Case
  {
    std::string json;
    std::string message;
  };
  const std::string line = R"("kind": "line", "title": "t", "x_label": "x", "y_label": "y", "levels": [])";
  const std::vector<Case> cases = {
      {"{", "is not valid JSON"},
      {R"({"plots": []})", R"(expected {"charts": [...]})"},
      {R"({"charts": [{"file": "a.png", )" + line + "}]}", "chart 1 (a.png): missing 'series'"},
      {R"({"charts": [{"file": "a.png", "kind": "pie"}]})", "chart 1 (a.png): 'kind' is 'pie', not one of bar, line"},
      {R"({"charts": [{"file": "../a.png", "kind": "line"}]})", "'file' must be a plain PNG name"},
      {R"({"charts": [{"file": "a.png", "series": [{"label": "s", "x": [1], "y": ["one"], "line": true}], )" + line +
           "}]}",
       "'y' holds 'one', not a number or null"},
      {R"({"charts": [{"file": "a.png", "series": [{"label": "s", "x": [1, 2], "y": [1], "line": true}], )" + line +
           "}]}",
       "series 's' has 2 x and 1 y values"},
  };
  for (const Case& c : cases)
  {
    std::ofstream(dir / "charts.json") << c.json;
    const CliRun run = plotCharts((dir / "charts.json").string());
    EXPECT_EQ(run.exit_code, 2) << c.json;
    EXPECT_TRUE(has(run.errors, "plot_charts: ")) << run.errors;
    EXPECT_TRUE(has(run.errors, c.message)) << c.json << "\n" << run.errors;
  }
  // Every chart is checked before any is written: a bad second chart leaves no first PNG.
  std::ofstream(dir / "charts.json") << R"({"charts": [{"file": "good.png", "series": [], )" + line +
                                            R"(}, {"file": "bad.png", "kind": "pie"}]})";
  EXPECT_EQ(plotCharts((dir / "charts.json").string()).exit_code, 2);
  EXPECT_FALSE(fs::exists(dir / "good.png"));
  const CliRun missing = plotCharts((dir / "missing.json").string());
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_TRUE(has(missing.errors, "cannot read " + (dir / "missing.json").string())) << missing.errors;
  EXPECT_EQ(plotCharts("").exit_code, 2);
}

// A small evaluation end to end: the report, the charts' data and every chart it shows drawn.
TEST(SpoolEvalCli, WritesTheReportAndDrawsEveryChartItShows)
{
  const fs::path dir = freshDir("eval_cli") / "report";
  const CliRun run = spoolEval("--out " + dir.string() + " --count 2 --sizes 160x120 --repeats 1");
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  std::stringstream md;
  md << std::ifstream(dir / "report.md").rdbuf();
  const nlohmann::json charts = nlohmann::json::parse(std::ifstream(dir / "charts.json"))["charts"];
  ASSERT_EQ(charts.size(), 8u);  // five variant analyses, distance, yaw, tx_r
  for (const nlohmann::json& chart : charts)
  {
    const std::string file = chart["file"];
    EXPECT_TRUE(has(md.str(), "(" + file + ")")) << file;
    expectDrawnChart(dir / file);
  }
}

TEST(SpoolEvalCli, NoChartsWritesTheirDataAndSaysHowToDrawThem)
{
  const fs::path dir = freshDir("eval_cli_no_charts") / "report";
  const CliRun run = spoolEval("--out " + dir.string() + " --count 2 --sizes 160x120 --repeats 1 --no-charts");
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  EXPECT_TRUE(fs::exists(dir / "report.md"));
  EXPECT_TRUE(fs::exists(dir / "charts.json"));
  EXPECT_FALSE(fs::exists(dir / "distance.png"));
  EXPECT_TRUE(has(run.errors, "scripts/plot_charts.py " + (dir / "charts.json").string())) << run.errors;
}

TEST(SpoolEvalCli, BadOptionsExitTwoNamingTheOption)
{
  const std::string out = "--out " + ::testing::TempDir() + "eval_bad";
  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {out + " --charts", "unknown option '--charts'"},
           {"--count 2", "--out is required"},
           {out + " --sizes 160x", "--sizes: '160x' is not WIDTHxHEIGHT (32-4096 each)"}})
  {
    const CliRun run = spoolEval(args);
    EXPECT_EQ(run.exit_code, 2) << args;
    EXPECT_TRUE(has(run.errors, "spool_eval: " + message)) << args << "\n" << run.errors;
  }
}

TEST(SpoolSimCli, OracleTrialsPrintALineEachASummaryAndThePictures)
{
  const fs::path dir = fs::temp_directory_path() / ("spool_sim_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const CliRun run = spoolSim("--trials 3 --seed 5 --oracle --width 160 --height 120 --pictures " + dir.string());
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  ASSERT_EQ(run.lines.size(), 4u) << run.errors;
  for (int i = 0; i < 3; ++i)
  {
    const auto trial = nlohmann::json::parse(run.lines[static_cast<std::size_t>(i)]);
    EXPECT_EQ(trial["outcome"], "inserted");
    EXPECT_LE(trial["back_miss_mm"].get<double>(), trial["tolerance_mm"].get<double>());
  }
  const auto summary = nlohmann::json::parse(run.lines[3])["summary"];
  EXPECT_EQ(summary["trials"], 3);
  EXPECT_EQ(summary["controller"], "oracle");
  EXPECT_EQ(summary["outcomes"]["inserted"], 3);
  std::ifstream trials(dir / "trials.jsonl");
  std::string line;
  int lines = 0;
  while (std::getline(trials, line))
    lines += nlohmann::json::parse(line)["trajectory"].size() > 10 ? 1 : 0;
  EXPECT_EQ(lines, 3);
  EXPECT_FALSE(cv::imread((dir / "trajectories.png").string()).empty());
  fs::remove_all(dir);
}

TEST(SpoolSimCli, FramesKeepsEveryFrameWithItsTruthAndTheCamera)
{
  // A 3-period trial (a timeout) written as spool_render writes a set, for spool_detect to replay.
  const fs::path dir = fs::temp_directory_path() / ("spool_sim_frames_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const CliRun run =
      spoolSim("--trials 1 --seed 5 --oracle --width 160 --height 120 --max-steps 3 --frames " + dir.string());
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  EXPECT_EQ(nlohmann::json::parse(run.lines.at(0))["outcome"], "timeout");
  const fs::path trial = dir / "5";
  const sv::CameraIntrinsics camera = sv::loadCameraInfoYaml((trial / "camera_info.yaml").string());
  EXPECT_EQ(cv::Size(camera.width, camera.height), cv::Size(160, 120));
  for (const char* name : {"frame_00000", "frame_00001", "frame_00002"})
  {
    EXPECT_EQ(cv::imread((trial / (std::string(name) + ".png")).string()).size(), cv::Size(160, 120)) << name;
    std::ifstream json(trial / (std::string(name) + ".json"));
    const auto truth = nlohmann::json::parse(json);
    EXPECT_GT(truth["flange"]["r"].get<double>(), 5.0) << name;
    EXPECT_GT(truth["distance"].get<double>(), 0.8) << name;
  }
  EXPECT_FALSE(fs::exists(trial / "frame_00003.png"));
  fs::remove_all(dir);
}

TEST(SpoolSimCli, ConfigFilesGivenAgainOverrideTheOnesBefore)
{
  // The robot's mount over the detector's YAML, as docs/closed_loop.md runs the trials; a bad key
  // in the second file is found, so the second file is read too.
  const std::string config = std::string(SPOOL_CONFIG_DIR);
  const CliRun run = spoolSim("--trials 1 --seed 5 --oracle --width 160 --height 120 --max-steps 2 --config " + config +
                              "/default.yaml --config " + config + "/forklift_mount.yaml");
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  const auto summary = nlohmann::json::parse(run.lines.at(1))["summary"];
  EXPECT_EQ(summary["config"], nlohmann::json::array({config + "/default.yaml", config + "/forklift_mount.yaml"}));
  const std::string bad = ::testing::TempDir() + "spool_sim_bad_mount.yaml";
  std::ofstream(bad) << "track_level_pitch_sigma: 0.5\n";
  const CliRun refused = spoolSim("--trials 1 --oracle --config " + config + "/default.yaml --config " + bad);
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_TRUE(has(refused.errors, "track_level_pitch_sigma")) << refused.errors;
  std::remove(bad.c_str());
}

TEST(SpoolSimCli, BadOptionsExitTwoNamingTheOption)
{
  for (const std::string bad :
       {"--trials 0", "--rate -1", "--width 10 --height 10", "--frobnicate 1", "--target-hint -0.1"})
  {
    const CliRun run = spoolSim(bad);
    EXPECT_EQ(run.exit_code, 2) << bad << ": " << run.errors;
    EXPECT_TRUE(has(run.errors, bad.substr(0, bad.find(' ')))) << bad << ": " << run.errors;
  }
}
