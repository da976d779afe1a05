// The command-line contract of spool_detect (DESIGN.md §6), checked on the real binary.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli_process.h"
#include "synthetic.h"

namespace fs = std::filesystem;
using spool_vision::CameraIntrinsics;
using spool_vision::test::CliRun;
using spool_vision::test::drawScene;
using spool_vision::test::spoolAt;

namespace
{
CliRun spoolDetect(const std::string& args)
{
  return spool_vision::test::runCommand(std::string(SPOOL_DETECT_BIN) + " " + args);
}

bool has(const std::string& line, const std::string& fragment)
{
  return line.find(fragment) != std::string::npos;
}

// A number after "key": in a flat JSON line, NaN if absent or null.
double number(const std::string& line, const std::string& key)
{
  const auto at = line.find("\"" + key + "\": ");
  if (at == std::string::npos)
    return std::nan("");
  return std::strtod(line.c_str() + at + key.size() + 4, nullptr);
}

class SpoolDetectCli : public ::testing::Test
{
protected:
  void SetUp() override
  {
    dir_ = fs::path(::testing::TempDir()) / "spool_detect_cli";
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "set");
    const auto vga = CameraIntrinsics::thesisDefault(640, 480);
    cv::imwrite((dir_ / "set/a_spool.png").string(), drawScene({640, 480}, {spoolAt(vga, 0.8, 0.0, 0.06)}));
    cv::imwrite((dir_ / "set/b_empty.jpg").string(), drawScene({640, 480}, {}));
    std::ofstream(dir_ / "set/c_broken.png") << "not an image";
    std::ofstream(dir_ / "set/notes.txt") << "ignored: not an image extension";
  }
  fs::path dir_;
};
}  // namespace

TEST_F(SpoolDetectCli, OneJsonLinePerImageInOrder)
{
  const CliRun run = spoolDetect((dir_ / "set").string());
  ASSERT_EQ(run.lines.size(), 3u);
  EXPECT_EQ(run.exit_code, 1);  // c_broken.png cannot be read

  const std::string& spool = run.lines[0];
  EXPECT_TRUE(has(spool, "\"image\": \"" + (dir_ / "set/a_spool.png").string() + "\"")) << spool;
  EXPECT_TRUE(has(spool, "\"width\": 640, \"height\": 480")) << spool;
  EXPECT_TRUE(has(spool, "\"detected\": true")) << spool;
  EXPECT_TRUE(has(spool, "\"hole_detected\": true")) << spool;
  EXPECT_NEAR(number(spool, "distance"), std::hypot(0.8, 0.06), 0.008) << spool;
  EXPECT_TRUE(has(spool, "\"flange\": {\"x\": ")) << spool;
  EXPECT_TRUE(has(spool, "\"reference\": {\"x\": ")) << spool;
  EXPECT_GE(number(spool, "time_ms"), 0.0);

  const std::string& empty = run.lines[1];
  EXPECT_TRUE(has(empty, "\"detected\": false")) << empty;
  EXPECT_TRUE(has(empty, "\"distance\": null")) << empty;
  EXPECT_TRUE(has(empty, "\"flange\": null")) << empty;

  const std::string& broken = run.lines[2];
  EXPECT_TRUE(has(broken, "c_broken.png\", \"error\": ")) << broken;
}

TEST_F(SpoolDetectCli, ExitsZeroWhenEveryImageWorked)
{
  const CliRun run = spoolDetect((dir_ / "set/a_spool.png").string() + " " + (dir_ / "set/b_empty.jpg").string());
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_EQ(run.lines.size(), 2u);
}

TEST_F(SpoolDetectCli, MissingFileIsAnErrorLine)
{
  const CliRun run = spoolDetect((dir_ / "nope.png").string());
  EXPECT_EQ(run.exit_code, 1);
  ASSERT_EQ(run.lines.size(), 1u);
  EXPECT_TRUE(has(run.lines[0], "\"error\"")) << run.lines[0];
}

TEST_F(SpoolDetectCli, BadOptionsAndConfigsExitTwo)
{
  std::ofstream(dir_ / "bad.yaml") << "sensitivity: 3\n";
  EXPECT_EQ(spoolDetect("--config " + (dir_ / "bad.yaml").string() + " " + dir_.string()).exit_code, 2);
  EXPECT_EQ(spoolDetect("--mode hough " + dir_.string()).exit_code, 2);
  const CliRun unknown = spoolDetect("--frobnicate " + dir_.string());
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.errors.find("spool_detect: unknown option '--frobnicate'"), std::string::npos) << unknown.errors;
  EXPECT_EQ(spoolDetect("--camera-info /nonexistent.yaml " + dir_.string()).exit_code, 2);
  EXPECT_EQ(spoolDetect("").exit_code, 2);
}

TEST_F(SpoolDetectCli, ConfigAndModeAreApplied)
{
  const std::string seed = std::string(SPOOL_CONFIG_DIR) + "/seed.yaml";
  // Seed config at 160x120 uses the fixed thesis reference (80, 50).
  const auto qqvga = CameraIntrinsics::thesisDefault(160, 120);
  cv::imwrite((dir_ / "small.png").string(), drawScene({160, 120}, {spoolAt(qqvga, 0.8, 0.0, 0.06)}));
  const CliRun run = spoolDetect("--config " + seed + " --mode cht " + (dir_ / "small.png").string());
  ASSERT_EQ(run.exit_code, 0);
  ASSERT_EQ(run.lines.size(), 1u);
  EXPECT_TRUE(has(run.lines[0], "\"reference\": {\"x\": 80.00, \"y\": 50.00}")) << run.lines[0];
  EXPECT_TRUE(has(run.lines[0], "\"detected\": true")) << run.lines[0];
}

namespace
{
// Pixels of the overlay's text corner (top left, where the labels go) that stand out from a
// background of grey level `background`: a label is readable when it brings the opposite shade.
int contrastingTextPixels(const cv::Mat& bgr, int background)
{
  const cv::Mat corner = bgr(cv::Rect(0, 0, bgr.cols / 2, bgr.rows / 6));
  cv::Mat grey;
  cv::cvtColor(corner, grey, cv::COLOR_BGR2GRAY);
  return cv::countNonZero(background > 127 ? grey < 64 : grey > 191);
}
}  // namespace

TEST_F(SpoolDetectCli, OverlayWritesWhatTheDetectorSawPerImage)
{
  const fs::path out = dir_ / "overlay";
  const CliRun run = spoolDetect("--overlay " + out.string() + " " + (dir_ / "set").string());
  ASSERT_EQ(run.lines.size(), 3u);
  EXPECT_EQ(run.exit_code, 1);  // c_broken.png, as without --overlay
  EXPECT_TRUE(has(run.lines[0], "\"overlay\": \"" + (out / "a_spool.png").string() + "\"")) << run.lines[0];
  EXPECT_TRUE(has(run.lines[1], "\"overlay\": \"" + (out / "b_empty.png").string() + "\"")) << run.lines[1];
  EXPECT_FALSE(fs::exists(out / "c_broken.png"));

  const cv::Mat spool = cv::imread((out / "a_spool.png").string());
  ASSERT_EQ(spool.size(), cv::Size(640, 480));
  // The flange rim in red where the JSON puts it (top of the circle).
  const std::string flange = run.lines[0].substr(run.lines[0].find("\"flange\""));
  const double x = number(flange, "x");
  const double y = number(flange, "y");
  const double r = number(flange, "r");
  ASSERT_TRUE(std::isfinite(x) && std::isfinite(y) && std::isfinite(r)) << run.lines[0];
  cv::Mat red;
  cv::inRange(spool(cv::Rect(static_cast<int>(x) - 3, static_cast<int>(y - r) - 3, 7, 7)), cv::Scalar(0, 0, 180),
              cv::Scalar(90, 90, 255), red);
  EXPECT_GT(cv::countNonZero(red), 0) << "no red flange rim at the top of (" << x << ", " << y << ", " << r << ")";
}

TEST_F(SpoolDetectCli, OverlayTextIsReadableOnBrightAndDarkFrames)
{
  const fs::path out = dir_ / "overlay_shades";
  fs::create_directories(dir_ / "shades");
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(160, 120)})
    for (const int shade : {0, 255})
      cv::imwrite(
          (dir_ / "shades" / ("s" + std::to_string(size.width) + "_" + std::to_string(shade) + ".png")).string(),
          cv::Mat(size, CV_8UC1, cv::Scalar(shade)));
  ASSERT_EQ(spoolDetect("--overlay " + out.string() + " " + (dir_ / "shades").string()).exit_code, 0);
  for (const int width : {640, 160})
    for (const int shade : {0, 255})
    {
      const std::string name = "s" + std::to_string(width) + "_" + std::to_string(shade) + ".png";
      const cv::Mat overlay = cv::imread((out / name).string());
      ASSERT_FALSE(overlay.empty()) << name;
      // "No spool" takes a few dozen pixels of glyph at 160x120.
      EXPECT_GT(contrastingTextPixels(overlay, shade), width / 8) << name;
    }
}

TEST_F(SpoolDetectCli, OverlayFolderThatCannotBeMadeExitsTwo)
{
  std::ofstream(dir_ / "a_file") << "in the way";
  const CliRun run = spoolDetect("--overlay " + (dir_ / "a_file" / "sub").string() + " " + (dir_ / "set").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.errors.find("--overlay"), std::string::npos) << run.errors;
  EXPECT_TRUE(run.lines.empty());
}

namespace
{
// Frames of a drawn approach at 20 cm/s and 30 Hz, from 0.9 m, named in order.
std::vector<std::string> writeApproach(const fs::path& dir, int count)
{
  fs::create_directories(dir);
  const auto vga = CameraIntrinsics::thesisDefault(640, 480);
  std::vector<std::string> paths;
  for (int i = 0; i < count; ++i)
  {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%03d.png", i);
    paths.push_back((dir / name).string());
    cv::imwrite(paths.back(), drawScene({640, 480}, {spoolAt(vga, 0.9 - 0.2 * i / 30.0, 0.0, 0.06)}));
  }
  return paths;
}

// A field's text after "key": (to the next ',' or '}'), for the tracker's words and counts.
std::string field(const std::string& line, const std::string& key)
{
  const auto at = line.find("\"" + key + "\": ");
  if (at == std::string::npos)
    return "";
  const auto start = at + key.size() + 4;
  return line.substr(start, line.find_first_of(",}", start) - start);
}
}  // namespace

TEST_F(SpoolDetectCli, TrackFollowsTheImagesInOrderAndAddsItsFields)
{
  writeApproach(dir_ / "approach", 6);
  const CliRun run = spoolDetect("--track " + (dir_ / "approach").string());
  ASSERT_EQ(run.exit_code, 0) << run.errors;
  ASSERT_EQ(run.lines.size(), 6u);
  for (std::size_t i = 0; i < run.lines.size(); ++i)
  {
    const std::string& line = run.lines[i];
    SCOPED_TRACE(line);
    EXPECT_EQ(field(line, "track_age"), std::to_string(i + 1));
    // Held from the first image, published from the track_confirm_frames-th (default 3) on.
    if (i + 1 < 3)
    {
      EXPECT_EQ(field(line, "track_state"), "\"searching\"");
      EXPECT_EQ(field(line, "detected"), "false");
      continue;
    }
    EXPECT_EQ(field(line, "track_state"), "\"tracking\"");
    EXPECT_NEAR(number(line, "distance"), number(line, "raw_distance"), 0.01);
    EXPECT_TRUE(has(line, "\"position_covariance\": [")) << line;
    EXPECT_TRUE(has(line, "\"axis\": {\"x\": ")) << line;
  }
  // Without --track: the per-frame fields only, the axis among them.
  const CliRun plain = spoolDetect((dir_ / "approach").string());
  ASSERT_EQ(plain.lines.size(), 6u);
  EXPECT_FALSE(has(plain.lines[0], "track_state"));
  EXPECT_TRUE(has(plain.lines[0], "\"axis\": {\"x\": ")) << plain.lines[0];
}

TEST_F(SpoolDetectCli, StdinAnswersEachLineAtOnceAndTheTrackerGoesOnPastABadPath)
{
  const std::vector<std::string> frames = writeApproach(dir_ / "approach", 3);
  // A pipe both ways: each answer must come before the next path is written (flushed at once).
  int to_child[2];
  int from_child[2];
  ASSERT_EQ(pipe(to_child), 0);
  ASSERT_EQ(pipe(from_child), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0)
  {
    dup2(to_child[0], 0);
    dup2(from_child[1], 1);
    close(to_child[1]);
    close(from_child[0]);
    execl(SPOOL_DETECT_BIN, SPOOL_DETECT_BIN, "--stdin", static_cast<char*>(nullptr));
    _exit(127);
  }
  close(to_child[0]);
  close(from_child[1]);
  FILE* answers = fdopen(from_child[0], "r");
  auto ask = [&](const std::string& path)
  {
    const std::string line = path + "\n";
    EXPECT_EQ(write(to_child[1], line.data(), line.size()), static_cast<ssize_t>(line.size()));
    pollfd ready{from_child[0], POLLIN, 0};
    EXPECT_EQ(poll(&ready, 1, 20000), 1) << "no answer to " << path << " within 20 s";
    char buffer[8192] = {};
    return std::string(fgets(buffer, sizeof(buffer), answers) ? buffer : "");
  };
  const std::string first = ask(frames[0]);
  const std::string bad = ask((dir_ / "nope.png").string());
  const std::string second = ask(frames[1]);
  const std::string third = ask(frames[2]);
  close(to_child[1]);
  int status = 0;
  waitpid(pid, &status, 0);
  fclose(answers);
  EXPECT_EQ(field(first, "track_age"), "1") << first;
  EXPECT_TRUE(has(bad, "\"error\"")) << bad;
  EXPECT_EQ(field(second, "track_age"), "2") << second;
  EXPECT_EQ(field(third, "track_age"), "3") << third;
  EXPECT_EQ(field(third, "track_state"), "\"tracking\"") << third;
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);  // an image failed
  // --stdin takes no PATH.
  EXPECT_EQ(spoolDetect("--stdin " + frames[0]).exit_code, 2);
}

// A request line per frame on --stdin, written to `name` in the test's folder; the answers.
CliRun stdinRequests(const fs::path& dir, const std::string& name, const std::vector<std::string>& requests)
{
  const fs::path file = dir / name;
  std::ofstream out(file);
  for (const auto& r : requests)
    out << r << "\n";
  out.close();
  return spoolDetect("--stdin < " + file.string());
}

TEST_F(SpoolDetectCli, StdinRequestsGiveTheCamerasMotionAndTheTracksFollowIt)
{
  // The camera stands still, then slides 6 cm left within one frame (at 0.9 m, 50 px of image):
  // the gate refuses the jump without the motion, and fuses it with the motion the node's odometry
  // would give.
  const auto vga = CameraIntrinsics::thesisDefault(640, 480);
  std::vector<std::string> with_motion;
  std::vector<std::string> plain;
  for (int i = 0; i < 6; ++i)
  {
    const std::string path = (dir_ / ("slide_" + std::to_string(i) + ".png")).string();
    const bool slid = i >= 4;
    cv::imwrite(path, drawScene({640, 480}, {spoolAt(vga, 0.9, slid ? 0.0 : -0.06, 0.06)}));
    plain.push_back(path);
    const std::string t = i == 4 ? "0.06" : "0";
    with_motion.push_back("{\"image\": \"" + path + "\", \"motion\": {\"rotation\": [1, 0, 0, 0, 1, 0, 0, 0, 1], " +
                          "\"translation\": [" + t + ", 0, 0]}}");
  }
  const CliRun followed = stdinRequests(dir_, "with_motion.txt", with_motion);
  ASSERT_EQ(followed.exit_code, 0) << followed.errors;
  ASSERT_EQ(followed.lines.size(), 6u);
  const std::string& last = followed.lines[5];
  EXPECT_EQ(field(last, "track_age"), "6") << last;
  EXPECT_EQ(field(last, "track_state"), "\"tracking\"") << last;
  EXPECT_EQ(field(last, "rejected"), "0") << last;
  EXPECT_NEAR(number(last, "x"), 0.0, 0.005) << last;
  const CliRun alone = stdinRequests(dir_, "plain.txt", plain);
  ASSERT_EQ(alone.lines.size(), 6u);
  EXPECT_NE(field(alone.lines[4], "rejected"), "0") << alone.lines[4];
}

TEST_F(SpoolDetectCli, StdinRequestsGiveATargetHintAndOnlyThatSpoolIsFollowed)
{
  // Two spools 40 cm apart at 1.1 m: each is followed where the hint puts it.
  const auto vga = CameraIntrinsics::thesisDefault(640, 480);
  const std::string path = (dir_ / "two.png").string();
  cv::imwrite(path, drawScene({640, 480}, {spoolAt(vga, 1.1, -0.2, 0.06), spoolAt(vga, 1.1, 0.2, 0.06)}));
  for (const double x : {-0.2, 0.2})
  {
    std::vector<std::string> requests;
    for (int i = 0; i < 4; ++i)
      requests.push_back("{\"image\": \"" + path + "\", \"target_hint\": {\"x\": " + std::to_string(x + 0.03) +
                         ", \"y\": 0.06, \"z\": 1.1, \"radius\": 0.15}}");
    const CliRun run = stdinRequests(dir_, "hint.txt", requests);
    ASSERT_EQ(run.exit_code, 0) << run.errors;
    ASSERT_EQ(run.lines.size(), 4u);
    SCOPED_TRACE(run.lines[3]);
    EXPECT_EQ(field(run.lines[3], "track_state"), "\"tracking\"");
    EXPECT_NEAR(number(run.lines[3], "x"), x, 0.01);
  }
}

TEST_F(SpoolDetectCli, StdinRequestsThatAreNotOneSayWhyAndTheToolGoesOn)
{
  const std::string spool = (dir_ / "set/a_spool.png").string();
  const CliRun run = stdinRequests(
      dir_, "bad.txt",
      {"{\"image\": 3}", "{not json", "{\"image\": \"" + spool + "\", \"motion\": {\"rotation\": [1, 0, 0]}}",
       "{\"image\": \"" + spool +
           "\", \"motion\": {\"rotation\": [2, 0, 0, 0, 1, 0, 0, 0, 1], \"translation\": [0, 0, 0]}}",
       "{\"image\": \"" + spool + "\", \"target_hint\": {\"x\": 0, \"y\": 0, \"z\": 1, \"radius\": -1}}",
       "{\"image\": \"" + spool + "\", \"stamp\": 5}", "{\"image\": \"" + spool + "\", \"stamp\": 4}", spool});
  EXPECT_EQ(run.exit_code, 1);
  ASSERT_EQ(run.lines.size(), 8u);
  EXPECT_TRUE(has(run.lines[0], "\\\"image\\\" must be the image's path")) << run.lines[0];
  EXPECT_TRUE(has(run.lines[1], "not a JSON object")) << run.lines[1];
  EXPECT_TRUE(has(run.lines[2], "\\\"rotation\\\" must be an array of 9 finite numbers")) << run.lines[2];
  EXPECT_TRUE(has(run.lines[3], "must be a rotation matrix")) << run.lines[3];
  EXPECT_TRUE(has(run.lines[4], "\\\"radius\\\" of \\\"target_hint\\\" must be > 0 m")) << run.lines[4];
  EXPECT_FALSE(has(run.lines[5], "\"error\"")) << run.lines[5];
  EXPECT_TRUE(has(run.lines[6], "stamps must increase")) << run.lines[6];
  // A plain path after them: its stamp is its slot (7 / 30 s), after the 5 s given: refused too.
  EXPECT_TRUE(has(run.lines[7], "stamps must increase")) << run.lines[7];
}
