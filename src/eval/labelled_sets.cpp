#include <array>
#include <cmath>
#include <random>
#include <string>
#include <utility>

#include "spool_vision/eval/evaluation.h"

namespace spool_vision
{
namespace
{
constexpr double kDeg = M_PI / 180.0;

constexpr std::array<std::pair<FrameSet, const char*>, 9> kSetNames = {{{FrameSet::kMain, "main"},
                                                                        {FrameSet::kApproach, "approach"},
                                                                        {FrameSet::kNegatives, "negatives"},
                                                                        {FrameSet::kHard, "hard"},
                                                                        {FrameSet::kDistorted, "distorted"},
                                                                        {FrameSet::kApproachHard, "approach_hard"},
                                                                        {FrameSet::kOblique, "oblique"},
                                                                        {FrameSet::kPacked, "packed"},
                                                                        {FrameSet::kPackedOblique, "packed_oblique"}}};

std::uint64_t frameSeed(std::uint64_t seed, int index)
{
  return seed * 1000003ULL + static_cast<std::uint64_t>(index) * 7919ULL + 17ULL;
}

SceneKind randomNegative(cv::RNG& rng)
{
  static const SceneKind kinds[] = {SceneKind::kEmptySlot, SceneKind::kPlate, SceneKind::kTapeRoll, SceneKind::kCan};
  return kinds[rng.uniform(0, 4)];
}

// One frame of the main, negatives or hard set: random scene, random pose over the working
// range. The hard set's camera rides anywhere from level with the bore axis to 8 cm above it.
void randomFrame(FrameSet set, std::uint64_t set_seed, int index, SceneParams& scene, CameraPose& pose)
{
  const std::uint64_t seed = frameSeed(set_seed, index);
  // cv::RNG's first draws follow its seed almost linearly, so consecutive frame seeds would put
  // the poses on a lattice; one Mersenne Twister step scatters them.
  cv::RNG rng{std::mt19937_64(seed)()};
  SceneKind kind = SceneKind::kSpool;
  if (set == FrameSet::kNegatives || rng.uniform(0.0, 1.0) < 0.15)
    kind = randomNegative(rng);
  const bool oblique = set == FrameSet::kOblique || set == FrameSet::kPackedOblique;
  const bool hard = set == FrameSet::kHard || set == FrameSet::kPacked || oblique;
  scene = hard ? randomHardScene(kind, seed) : randomScene(kind, seed);
  if (set == FrameSet::kPacked || set == FrameSet::kPackedOblique)
    packShelf(seed, scene);
  // Drawn last to first: the order in which the compiler evaluated these as call arguments
  // when the main set was first rendered, which keeps the main set's frames as they were.
  const double pitch = rng.uniform(-2.0, 2.0) * kDeg;
  const double height = hard ? rng.uniform(0.0, 0.08) : rng.uniform(0.05, 0.07);
  const double heading = rng.uniform(-5.0, 5.0) * kDeg;
  const double bearing = rng.uniform(-20.0, 20.0) * kDeg;
  const double distance = rng.uniform(0.5, 1.1);
  pose = bearingPose(distance, bearing, heading, height, pitch);
  if (oblique)
  {
    // The camera beside the slot: the line of sight 25-40 deg off the spool axis, either side
    // (bearingPose: the view off the axis is bearing + heading). Drawn after main's draws.
    const double view = (rng.uniform(0.0, 1.0) < 0.5 ? 1.0 : -1.0) * rng.uniform(25.0, 40.0) * kDeg;
    const double oblique_bearing = rng.uniform(-15.0, 15.0) * kDeg;
    pose = bearingPose(distance, oblique_bearing, view - oblique_bearing, height, pitch);
  }
  if (hard)
  {
    // The rod's top edge must stay below the hole's bottom rim in the image (angles below the
    // optical axis), or the set would hide the hole it scores.
    const double rod_top = SpoolRenderer::kPullerOffsetY - 0.5 * SpoolRenderer::kPullerDiameter;
    const double hole_bottom = (height + 0.5 * scene.hole_diameter) / distance + std::abs(pitch);
    scene.puller_rod_length = std::min(scene.puller_rod_length, 0.8 * rod_top / hole_bottom);
  }
}

// A frame near the end of an approach, scene drawn afresh: 48-62 cm of depth (the insertion
// window and a little beyond), the puller axis within 3 mm sideways and 1.5 mm up or down of the
// bore's front centre, the heading within 0.6 deg and the pitch within 0.3 deg of the bore axis,
// so that it clears the bore wall on about 60% of the frames and misses it narrowly on the rest.
void nearAlignedFrame(std::uint64_t set_seed, int index, SceneParams& scene, CameraPose& pose)
{
  const std::uint64_t seed = frameSeed(set_seed, index) + 1;  // not main's frame `index`
  cv::RNG rng{std::mt19937_64(seed)()};
  scene = randomScene(SceneKind::kSpool, seed);
  const double depth = rng.uniform(0.48, 0.62);
  const double miss_x = rng.uniform(-0.003, 0.003);
  const double miss_y = rng.uniform(-0.0015, 0.0015);
  pose.yaw = rng.uniform(-0.6, 0.6) * kDeg;
  pose.pitch = rng.uniform(-0.3, 0.3) * kDeg;
  // The puller runs along the optical axis: it meets the face plane where these offsets put it
  // (to first order in the angles; the truth is exact).
  pose.lateral = miss_x - depth * std::tan(pose.yaw);
  pose.height = SpoolRenderer::kPullerOffsetY + miss_y + depth * std::tan(pose.pitch);
  pose.distance = std::sqrt(depth * depth + pose.height * pose.height + pose.lateral * pose.lateral);
}

// One frame of an approach: 110 cm to 50 cm of depth (distance is depth: ending at 50 cm of
// range would leave the last frame 3.6 mm short of the insertion window), the lateral and
// heading errors shrink by 80% of the way (about 62 cm) to zero, so the last frames inside 60 cm
// are aligned. `hard` (approach_hard): the hard set's webcam, faces (ribs, labels, gloss) and
// clutter on the shared shelf, a radial smear from driving at 10-30 cm/s, and half of the
// approaches ending just off instead: the puller aimed at the bore's front centre but turned
// 0.8-1.3 deg (its back end 2.8-4.5 mm off the bore's axis), or parallel 2.8-4 mm beside it.
void approachFrame(std::uint64_t set_seed, int index, int count, bool hard, SceneParams& scene, CameraPose& pose)
{
  const std::uint64_t shelf_seed = ~frameSeed(set_seed, 0);  // the shelf shared by all frames
  cv::RNG rng(shelf_seed);
  scene = hard ? randomHardScene(SceneKind::kSpool, shelf_seed) : randomScene(SceneKind::kSpool, shelf_seed);
  const double lateral0 = (rng.uniform(0, 2) ? 1.0 : -1.0) * rng.uniform(0.05, 0.15);
  const double heading0 = rng.uniform(-3.0, 3.0) * kDeg;
  const double s = count > 1 ? static_cast<double>(index) / (count - 1) : 1.0;
  const double left = std::pow(std::max(0.0, 1.0 - s / 0.8), 2.0);
  scene.seed = frameSeed(set_seed, index);  // fresh sensor noise per frame, same shelf
  // 110 to 51 cm deep: the last frame inside the insertion window, not on its 50 cm edge, where
  // a tenth of a millimetre of depth error would decide it.
  const double depth = 1.10 - 0.59 * s;
  double end_lateral = 0.0;
  double end_heading = 0.0;
  if (hard)
  {
    // Drawn after the plain approach's draws, which so stay the same.
    const double side = rng.uniform(0, 2) ? 1.0 : -1.0;
    const int ending = rng.uniform(0, 4);  // 0, 1: aligned; 2: turned; 3: beside
    if (ending == 2)
      end_heading = side * rng.uniform(0.8, 1.3) * kDeg;
    else if (ending == 3)
      end_lateral = side * rng.uniform(0.0028, 0.004);
    // A point at the image corner (~400 px at 480 rows) moves 400 v t / z px in a 1/30 s exposure.
    const double speed = rng.uniform(0.1, 0.3);
    scene.motion_blur = 400.0 * speed / 30.0 / depth;
    scene.motion_blur_radial = true;
    // The rod's top edge below the hole's bottom rim in the image, as in the hard set.
    const double rod_top = SpoolRenderer::kPullerOffsetY - 0.5 * SpoolRenderer::kPullerDiameter;
    const double hole_bottom = (SpoolRenderer::kPullerOffsetY + 0.5 * scene.hole_diameter) / depth;
    scene.puller_rod_length = std::min(scene.puller_rod_length, 0.8 * rod_top / hole_bottom);
  }
  pose.yaw = heading0 * left + end_heading * (1.0 - left);
  // A turned ending keeps the puller aimed at the bore's front centre (it meets the face plane
  // depth tan(yaw) to the side of where the camera stands).
  pose.lateral = lateral0 * left + (end_lateral - depth * std::tan(end_heading)) * (1.0 - left);
  pose.height = SpoolRenderer::kPullerOffsetY;  // the puller at the axis's height
  pose.pitch = 0.0;
  pose.distance = std::sqrt(depth * depth + pose.height * pose.height + pose.lateral * pose.lateral);
}
}  // namespace

const char* toString(FrameSet set)
{
  for (const auto& [named, name] : kSetNames)
    if (named == set)
      return name;
  return "?";
}

std::optional<FrameSet> frameSetNamed(const std::string& name)
{
  for (const auto& [set, set_name] : kSetNames)
    if (name == set_name)
      return set;
  return std::nullopt;
}

CameraPose bearingPose(double distance, double bearing, double heading, double height, double pitch)
{
  CameraPose pose;
  pose.distance = distance;
  pose.height = height;
  pose.yaw = heading;
  pose.pitch = pitch;
  pose.lateral = -std::sqrt(distance * distance - height * height) * std::sin(bearing + heading);
  return pose;
}

void setFrame(FrameSet set, std::uint64_t seed, int index, int count, SceneParams& scene, CameraPose& pose)
{
  if (set == FrameSet::kApproach || set == FrameSet::kApproachHard)
    approachFrame(seed, index, count, set == FrameSet::kApproachHard, scene, pose);
  else if (set == FrameSet::kDistorted && index % 3 == 2)
    nearAlignedFrame(seed, index, scene, pose);
  else
    // The distorted set's other frames are main's, so the two sets compare frame by frame.
    randomFrame(set == FrameSet::kDistorted ? FrameSet::kMain : set, seed, index, scene, pose);
}

const std::vector<double>& c270Distortion()
{
  // Barrel distortion of a C270-class lens (k1 about -0.2), a little decentring.
  static const std::vector<double> d = {-0.2, 0.05, 0.001, -0.0005, 0.0};
  return d;
}

CameraIntrinsics setCamera(FrameSet set, cv::Size size, double focal)
{
  CameraIntrinsics camera = CameraIntrinsics::thesisDefault(size.width, size.height);
  if (focal > 0.0)
    camera.fx = camera.fy = focal;
  if (set == FrameSet::kHard || set == FrameSet::kApproachHard || set == FrameSet::kOblique ||
      set == FrameSet::kPacked || set == FrameSet::kPackedOblique)
  {
    camera.cx += 0.015 * size.width;
    camera.cy -= 0.012 * size.height;
  }
  if (set == FrameSet::kDistorted)
  {
    camera.cx -= 0.01 * size.width;
    camera.cy += 0.008 * size.height;
    camera.distortion = c270Distortion();
  }
  return camera;
}

std::vector<RenderedFrame> renderSet(const SpoolRenderer& renderer, FrameSet set, std::uint64_t seed, int count,
                                     const Progress& progress)
{
  std::vector<RenderedFrame> frames;
  frames.reserve(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i)
  {
    SceneParams scene;
    CameraPose pose;
    setFrame(set, seed, i, count, scene, pose);
    frames.push_back(renderer.render(scene, pose));
    if (progress)
      progress("render", i + 1, count);
  }
  return frames;
}

}  // namespace spool_vision
