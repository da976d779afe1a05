// Regression tests on frames from outside the project (test/data/heldout_v1, another renderer and
// camera model, README in ../shared/cases): each stands for a kind of failure the detector had.
// Every frame is checked at 640x480 and, resampled the way a webcam's binned modes give it
// (INTER_AREA), at 320x240 and 160x120 with the same default.yaml.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include <yaml-cpp/yaml.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "spool_vision/io/config_io.h"
#include "spool_vision/spool_detector.h"
#include "spool_vision/spool_tracker.h"

using spool_vision::CameraIntrinsics;
using spool_vision::Circle;
using spool_vision::DetectorParams;
using spool_vision::PixelFormat;
using spool_vision::SpoolDetection;
using spool_vision::SpoolDetector;

namespace
{
const std::string kCases = std::string(SPOOL_TEST_DATA_DIR) + "/heldout_v1/";

struct Truth
{
  cv::Point3d flange;    ///< x, y, r in px at 640x480
  cv::Point3d hole;      ///< the bore's front rim
  double open_fraction;  ///< share of the bore that shows the wall behind
  double depth;          ///< m, z of the bore's front centre (camera optical frame)
  cv::Point2d offset;    ///< m, that centre's x, y relative to the puller axis
  double face_yaw;       ///< rad, where the spool axis points (atan2(x, z) of the axis)
};

Truth truthOf(const std::string& name)
{
  std::ifstream in(kCases + "truth.jsonl");
  std::string line;
  while (std::getline(in, line))
  {
    const YAML::Node frame = YAML::Load(line);  // JSON is YAML
    if (frame["name"].as<std::string>() != name)
      continue;
    auto circle = [&](const char* key)
    {
      const YAML::Node c = frame["target"][key];
      return cv::Point3d(c["x"].as<double>(), c["y"].as<double>(), c["r"].as<double>());
    };
    const YAML::Node target = frame["target"];
    return {circle("flange"),
            circle("hole"),
            target["hole"]["open_fraction"].as<double>(),
            target["distance_m"].as<double>(),
            {target["lateral_offset_m"][0].as<double>(), target["lateral_offset_m"][1].as<double>()},
            target["face_yaw_rad"].as<double>()};
  }
  ADD_FAILURE() << name << " is not in truth.jsonl";
  return {};
}

// A pixel position at 640 columns, at `width` columns (pixel centres are integers).
double scaled(double v, int width)
{
  const double s = width / 640.0;
  return (v + 0.5) * s - 0.5;
}

cv::Mat frameAt(const std::string& name, int width)
{
  cv::Mat image = cv::imread(kCases + name + ".png", cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty()) << name;
  if (!image.empty() && width != image.cols)
    cv::resize(image, image, cv::Size(width, width * 3 / 4), 0, 0, cv::INTER_AREA);
  return image;
}

// default.yaml with the case's camera for frames `width` columns wide.
SpoolDetection detect(const cv::Mat& image, int width)
{
  DetectorParams params;
  spool_vision::loadParamsYaml(std::string(SPOOL_CONFIG_DIR) + "/default.yaml", params);
  SpoolDetector detector(params);
  detector.setCamera(spool_vision::loadCameraInfoYaml(kCases + "camera_" + std::to_string(width) + ".yaml"));
  return detector.detect(image, PixelFormat::kBgr8);
}

// The target's flange within max(1.5 px, 2% r) (an ellipse's centre; the fit may lean on the back
// flange by a pixel) and radius within 3%; the bore's front rim within `hole_tol` px on centre and
// radius.
void expectTarget(const std::string& name, const cv::Mat& image, double hole_tol)
{
  const int width = image.cols;
  const Truth t = truthOf(name);
  const SpoolDetection d = detect(image, width);
  const double s = width / 640.0;
  SCOPED_TRACE(name + " at " + std::to_string(width) + " columns");
  ASSERT_TRUE(d.detected);
  const double flange_tol = std::max(1.5, 0.02 * t.flange.z * s);
  EXPECT_NEAR(d.flange.x, scaled(t.flange.x, width), flange_tol);
  EXPECT_NEAR(d.flange.y, scaled(t.flange.y, width), flange_tol);
  EXPECT_NEAR(d.flange.r, t.flange.z * s, 0.03 * t.flange.z * s);
  ASSERT_TRUE(d.hole_detected);
  EXPECT_LE(std::hypot(d.hole.x - scaled(t.hole.x, width), d.hole.y - scaled(t.hole.y, width)), hole_tol);
  EXPECT_NEAR(d.hole.r, t.hole.z * s, hole_tol);
  if (width < 640)
    return;
  // Where the bore shows through, the lit lens lies inside the front rim, higher (the camera is
  // above the bore axis, so the back opening appears higher) and smaller; a dark bore has none.
  if (t.open_fraction > 0.3)
  {
    ASSERT_TRUE(d.lens_detected);
    EXPECT_LT(d.lens.y, d.hole.y - 2.0);
    EXPECT_LT(d.lens.r, d.hole.r - 2.0);
  }
  else if (t.open_fraction == 0.0)
  {
    EXPECT_FALSE(d.lens_detected);
  }
}

class HeldoutCase : public ::testing::TestWithParam<const char*>
{
};
// heldout_v2's frames (640x480 through a C270 lens), the detector of config/default.yaml with
// their camera.
const std::string kCasesV2 = std::string(SPOOL_TEST_DATA_DIR) + "/heldout_v2/";

spool_vision::SpoolDetector heldoutV2Detector()
{
  DetectorParams params;
  spool_vision::loadParamsYaml(std::string(SPOOL_CONFIG_DIR) + "/default.yaml", params);
  spool_vision::SpoolDetector detector(params);
  detector.setCamera(spool_vision::loadCameraInfoYaml(kCasesV2 + "camera_640.yaml"));
  return detector;
}
}  // namespace

// The bore's front rim, found whatever its polarity: a dark bore in a grey face (pos_124,
// pos_239), the rim around a see-through lens, not the lens (pos_031, pos_167), ribbed faces at
// about 1 m (pos_032, pos_096), and the spool in front with a dark bore preferred to a lit one
// further off (pos_057).
TEST_P(HeldoutCase, TargetAndBoreFrontRimAt640x480)
{
  expectTarget(GetParam(), frameAt(GetParam(), 640), 1.0);
}

TEST_P(HeldoutCase, TargetAndBoreFrontRimAt320x240)
{
  expectTarget(GetParam(), frameAt(GetParam(), 320), 1.0);
}

// At the thesis' resolution the bore is 3-7 px across: its rim, not the lens, still within 1 px.
TEST_P(HeldoutCase, TargetAndBoreFrontRimAt160x120)
{
  expectTarget(GetParam(), frameAt(GetParam(), 160), 1.0);
}

INSTANTIATE_TEST_SUITE_P(Cases, HeldoutCase,
                         ::testing::Values("pos_124", "pos_239", "pos_031", "pos_167", "pos_032", "pos_096",
                                           "pos_057"));

// The spool in 3D (issue 10), from the flange rim as a 35 cm circle about the bore's front centre:
// depth (thesis Eq. 3.2's meaning) within 0.5%, the offset from the puller axis within 1 mm and
// the axis within 1 degree (pos_057's spool is turned 20 degrees, pos_124's 13.5).
TEST_P(HeldoutCase, SpoolIn3DAt640x480)
{
  const Truth t = truthOf(GetParam());
  const SpoolDetection d = detect(frameAt(GetParam(), 640), 640);
  ASSERT_TRUE(d.hole_detected);
  EXPECT_NEAR(d.distance, t.depth, 0.005 * t.depth);
  EXPECT_NEAR(d.lateral_offset, t.offset.x, 0.001);
  EXPECT_NEAR(d.position.y - 0.06, t.offset.y, 0.001);
  EXPECT_NEAR(d.axis_yaw, t.face_yaw, 1.0 * M_PI / 180.0);
}

// The case as handed: pos_031 resampled to 320x240 by the webcam model (not by us), which once
// gave a confident wrong target at the frame edge.
TEST(HeldoutCase, Pos031AsTheWebcamGivesItAt320x240)
{
  const cv::Mat image = cv::imread(kCases + "pos_031_320x240.png", cv::IMREAD_COLOR);
  ASSERT_EQ(image.cols, 320);
  expectTarget("pos_031", image, 1.0);
}

// The last frames of an approach from heldout_v2 (another renderer, a C270 lens, a ribbed face
// that overfills the frame at 59-55 cm, about 20 cm/s): alone, frames 36 and 37 report a rib ring
// as the flange, 0.87 and 0.85 m for 0.56 and 0.55. Followed in order (15 Hz), the track keeps
// the spool: its depth within 2% of the truth on every frame, never a jump. It is published from
// its track_confirm_frames-th fused frame on (seq2_36: before it is held, searching).
struct SequenceFrame
{
  std::string name;
  double depth;  ///< m, truth
  spool_vision::TrackedFrame result;
};

std::vector<SequenceFrame> followSeq2(int full_search_interval)
{
  DetectorParams params;
  spool_vision::loadParamsYaml(std::string(SPOOL_CONFIG_DIR) + "/default.yaml", params);
  params.tracker.full_search_interval = full_search_interval;
  spool_vision::TrackingDetector tracking(params);
  tracking.detector().setCamera(spool_vision::loadCameraInfoYaml(kCasesV2 + "camera_640.yaml"));
  std::ifstream truth(kCasesV2 + "truth.jsonl");
  std::vector<SequenceFrame> frames;
  for (std::string line; std::getline(truth, line);)
  {
    const YAML::Node frame = YAML::Load(line);
    const std::string name = frame["name"].as<std::string>();
    const cv::Mat image = cv::imread(kCasesV2 + name + ".png", cv::IMREAD_COLOR);
    EXPECT_FALSE(image.empty()) << name;
    if (image.empty())
      break;
    const double stamp = static_cast<double>(frames.size()) / 15.0;
    frames.push_back(
        {name, frame["target"]["distance_m"].as<double>(), tracking.process(image, PixelFormat::kBgr8, stamp)});
  }
  EXPECT_EQ(frames.size(), 4u);
  return frames;
}

std::string describe(const SequenceFrame& f)
{
  return f.name + ": " + spool_vision::toString(f.result.track.state) + ", raw " +
         std::to_string(f.result.raw.distance) + " m, published " + std::to_string(f.result.published.distance) +
         " m, truth " + std::to_string(f.depth) + " m";
}

// The track holds the spool from the first frame (its depth within 2%) and publishes it, at the
// same depth, from the track_confirm_frames-th frame on.
void expectHeld(const SequenceFrame& f)
{
  const int frame = std::stoi(f.name.substr(f.name.find('_') + 1)) - 34;
  const bool confirmed = frame + 1 >= DetectorParams().tracker.confirm_frames;
  EXPECT_EQ(f.result.track.state,
            confirmed ? spool_vision::TrackState::kTracking : spool_vision::TrackState::kSearching);
  EXPECT_NEAR(f.result.track.position.z, f.depth, 0.02 * f.depth);
  EXPECT_EQ(f.result.published.detected, confirmed);
  if (confirmed)
  {
    EXPECT_NEAR(f.result.published.distance, f.depth, 0.02 * f.depth);
  }
}

TEST(HeldoutSequence, TheTrackedWindowMeasuresTheFlangeNotTheRibRing)
{
  // Searched where the track puts the flange (radius within 10% and 3 sigma), the rib ring is
  // not a candidate: the detector itself measures the flange on every frame.
  for (const SequenceFrame& f : followSeq2(DetectorParams().tracker.full_search_interval))
  {
    SCOPED_TRACE(describe(f));
    expectHeld(f);
    EXPECT_NEAR(f.result.raw.distance, f.depth, 0.02 * f.depth);
  }
}

TEST(HeldoutSequence, EveryFrameSearchedWholeMeasuresTheFlange)
{
  // Every frame searched whole (track_full_search_interval 1): frames 36 and 37 used to give the
  // rib rings (0.87 and 0.85 m), which the gate refused; the bore measured at its own size now
  // says the ring is too small for it, and the whole-frame search finds the flange itself.
  const std::vector<SequenceFrame> frames = followSeq2(1);
  for (const SequenceFrame& f : frames)
  {
    SCOPED_TRACE(describe(f));
    expectHeld(f);
    EXPECT_NEAR(f.result.raw.distance, f.depth, 0.02 * f.depth);
    EXPECT_EQ(f.result.track.rejected, 0);
  }
}

TEST(HeldoutCase, ARibRingIsNotTheFlange)
{
  // heldout_v2 pos_024 (60 cm) and pos_089 (52 cm), 640x480 through a C270 lens: the flange
  // overfills the frame (cut at the bottom) and a raised rib ring 0.6 of its size is a whole,
  // concentric circle about the bore. It was reported as the flange (1.00 and 0.84 m); the
  // bore, measured at its own size, is 1.6 times what the ring allows.
  spool_vision::SpoolDetector detector = heldoutV2Detector();
  std::ifstream truth(kCasesV2 + "rib_frames.jsonl");
  int frames = 0;
  for (std::string line; std::getline(truth, line); ++frames)
  {
    const YAML::Node frame = YAML::Load(line);
    const std::string name = frame["name"].as<std::string>();
    SCOPED_TRACE(name);
    const cv::Mat image = cv::imread(kCasesV2 + name + ".png", cv::IMREAD_COLOR);
    ASSERT_FALSE(image.empty());
    const spool_vision::SpoolDetection d = detector.detect(image, PixelFormat::kBgr8);
    const YAML::Node target = frame["target"];
    ASSERT_TRUE(d.hole_detected);
    EXPECT_NEAR(d.distance, target["distance_m"].as<double>(), 0.02 * target["distance_m"].as<double>());
    EXPECT_NEAR(d.flange.r, target["flange"]["r"].as<double>(), 0.05 * target["flange"]["r"].as<double>());
    EXPECT_NEAR(d.hole.x, target["hole"]["x"].as<double>(), 2.0);
    EXPECT_NEAR(d.hole.y, target["hole"]["y"].as<double>(), 2.0);
  }
  EXPECT_EQ(frames, 2);
}

TEST(HeldoutCase, AnObliqueFlangeIsNotItsJointSilhouette)
{
  // heldout_v2 pos_073 (84 cm, 640x480 through a C270 lens): seen 33 deg off its axis, the flange
  // is an ellipse 0.85 as wide as it is high, and the back flange shows beside it. The Hough
  // search's best circle (r 191, its centre 44 px off) was reported: 0.73 m, the axis 39 deg the
  // wrong way. The rim measured about the bore over turned poses (RimPoseSearch) is the flange.
  spool_vision::SpoolDetector detector = heldoutV2Detector();
  std::ifstream truth(kCasesV2 + "oblique_frames.jsonl");
  std::string line;
  ASSERT_TRUE(std::getline(truth, line));
  const YAML::Node frame = YAML::Load(line);
  const YAML::Node target = frame["target"];
  const cv::Mat image = cv::imread(kCasesV2 + frame["name"].as<std::string>() + ".png", cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  const spool_vision::SpoolDetection d = detector.detect(image, PixelFormat::kBgr8);
  ASSERT_TRUE(d.hole_detected);
  const double depth = target["distance_m"].as<double>();
  EXPECT_NEAR(d.distance, depth, 0.02 * depth);
  // The flange's ellipse centre (frame px) and the axis's turn (truth: -21 deg).
  EXPECT_LE(
      std::hypot(d.flange.x - target["flange"]["x"].as<double>(), d.flange.y - target["flange"]["y"].as<double>()),
      6.0);
  EXPECT_NEAR(d.axis_yaw, target["face_yaw_rad"].as<double>(), 5.0 * M_PI / 180.0);
  // The bore's front rim is found 4 px off its centre here (a dark bore seen this far off).
  const YAML::Node centre = target["centre_px_distorted"];
  EXPECT_LE(std::hypot(d.hole.x - centre[0].as<double>(), d.hole.y - centre[1].as<double>()), 5.0);
}

namespace
{
// The line of heldout_v2's `file` (its truth.jsonl's lines) for frame `name`; a null node when
// it is missing.
YAML::Node v2Frame(const std::string& file, const std::string& name)
{
  std::ifstream in(kCasesV2 + file);
  for (std::string line; std::getline(in, line);)
  {
    YAML::Node frame = YAML::Load(line);  // JSON is YAML
    if (frame["name"].as<std::string>() == name)
      return frame;
  }
  ADD_FAILURE() << name << " is not in " << file;
  return YAML::Node();
}

// The target of heldout_v2's frame `name` (neighbour_frames.jsonl) where the truth puts it: depth
// within 1%, bearing within 0.2 deg, the bore's front centre (frame px) within 1.5 px, the axis's
// turn within 2 deg, the flange's size within 5%.
void expectV2Target(const std::string& name)
{
  SCOPED_TRACE(name);
  const YAML::Node frame = v2Frame("neighbour_frames.jsonl", name);
  ASSERT_TRUE(frame.IsDefined() && !frame.IsNull());
  const YAML::Node target = frame["target"];
  const cv::Mat image = cv::imread(kCasesV2 + name + ".png", cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  spool_vision::SpoolDetector detector = heldoutV2Detector();
  const SpoolDetection d = detector.detect(image, PixelFormat::kBgr8);
  ASSERT_TRUE(d.hole_detected);
  const double depth = target["distance_m"].as<double>();
  EXPECT_NEAR(d.distance, depth, 0.01 * depth);
  EXPECT_NEAR(d.yaw, target["yaw_rad"].as<double>(), 0.2 * M_PI / 180.0);
  const YAML::Node centre = target["centre_px_distorted"];
  EXPECT_LE(std::hypot(d.hole.x - centre[0].as<double>(), d.hole.y - centre[1].as<double>()), 1.5);
  EXPECT_NEAR(d.axis_yaw, target["face_yaw_rad"].as<double>(), 2.0 * M_PI / 180.0);
  EXPECT_NEAR(d.flange.r, target["flange"]["r"].as<double>(), 0.05 * target["flange"]["r"].as<double>());
}
}  // namespace

TEST(HeldoutCase, ARimFitDoesNotFollowANeighboursSilhouetteBesideIt)
{
  // heldout_v2 pos_002 (81 cm, 640x480 through a C270 lens): the neighbours' silhouettes touch
  // the target's rim left and right (and a lamp lights its glossy face). The rim fit from the
  // Hough cell followed them: radius +9%, 0.75 m, and its hole search found a ring off the bore
  // (score 0.55). The circle the most rim edges support nearby leads to the bore (score 1.0).
  expectV2Target("pos_002");
}

TEST(HeldoutCase, ATurnedTargetIsNotPassedOverForANeighbour)
{
  // heldout_v2 pos_013 (92 cm, bearing -8 deg, the spool turned 19 deg: 27 deg off its axis):
  // the Hough circle is the joint silhouette of its front and back flanges, 26 px off the bore,
  // and the neighbour at +17 deg was reported. The rim measured about the bore over turned poses
  // (RimPoseSearch) is the target; its bore is dark, not the lens of a hub ring around it.
  expectV2Target("pos_013");
}
