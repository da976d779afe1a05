#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "spool_vision/render/spool_renderer.h"

namespace sv = spool_vision;

namespace
{
constexpr double kDeg = M_PI / 180.0;

// A scene without texture, neighbours or camera imperfections, so edges are exactly where the
// geometry puts them.
sv::SceneParams cleanScene()
{
  sv::SceneParams s;
  s.ribs = false;
  s.label = false;
  s.blur_sigma = 0.0;
  s.noise_sigma = 0.0;
  s.jpeg_quality = 0;
  s.vignetting = 0.0;
  return s;
}

sv::CameraPose pose(double distance, double lateral = 0.0, double yaw = 0.0, double pitch = 0.0, double height = 0.06)
{
  sv::CameraPose p;
  p.distance = distance;
  p.lateral = lateral;
  p.yaw = yaw;
  p.pitch = pitch;
  p.height = height;
  return p;
}

cv::Mat grey(const cv::Mat& bgr)
{
  cv::Mat g;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  g.convertTo(g, CV_32F);
  return g;
}

double bilinear(const cv::Mat& img, double u, double v)
{
  const int u0 = static_cast<int>(std::floor(u));
  const int v0 = static_cast<int>(std::floor(v));
  const double a = u - u0;
  const double b = v - v0;
  auto at = [&](int x, int y) { return static_cast<double>(img.at<float>(y, x)); };
  return (1 - a) * (1 - b) * at(u0, v0) + a * (1 - b) * at(u0 + 1, v0) + (1 - a) * b * at(u0, v0 + 1) +
         a * b * at(u0 + 1, v0 + 1);
}

cv::Point2d ellipsePoint(const sv::ProjectedCircle& c, double t)
{
  const double ca = std::cos(c.angle);
  const double sa = std::sin(c.angle);
  const double x = c.semi_major * std::cos(t);
  const double y = c.semi_minor * std::sin(t);
  return {c.x + x * ca - y * sa, c.y + x * sa + y * ca};
}

// Signed distance (px, positive = outwards) from the rim point at parameter t to where the
// intensity profile along the outward normal crosses halfway between its inner and outer
// plateaus; nullopt when the profile leaves the image.
std::optional<double> edgeOffset(const cv::Mat& img, const sv::ProjectedCircle& c, double t, double reach)
{
  const cv::Point2d p = ellipsePoint(c, t);
  const cv::Point2d q = ellipsePoint(c, t + 1e-4);
  cv::Point2d n(q.y - p.y, -(q.x - p.x));  // outward for a counter-clockwise parameterisation
  n *= 1.0 / std::hypot(n.x, n.y);
  if ((p - cv::Point2d(c.x, c.y)).dot(n) < 0)
    n = -n;
  auto sample = [&](double s) { return bilinear(img, p.x + s * n.x, p.y + s * n.y); };
  for (double s : {-reach, reach})
  {
    const cv::Point2d e = p + s * n;
    if (e.x < 1 || e.y < 1 || e.x > img.cols - 2 || e.y > img.rows - 2)
      return std::nullopt;
  }
  const double inner = sample(-reach);
  const double outer = sample(reach);
  const double half = 0.5 * (inner + outer);
  const double step = 0.02;
  for (double s = -reach; s < reach; s += step)
  {
    const double a = sample(s) - half;
    const double b = sample(s + step) - half;
    if ((a <= 0) != (b <= 0))
      return s + step * a / (a - b);
  }
  return std::nullopt;
}

double meanInEllipse(const cv::Mat& img, const sv::ProjectedCircle& c, double shrink_px, double* max_value = nullptr,
                     double* fraction_above = nullptr, double threshold = 0.0)
{
  double sum = 0.0;
  double max_seen = 0.0;
  int count = 0;
  int above = 0;
  const double a = c.semi_major - shrink_px;
  const double b = c.semi_minor - shrink_px;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u)
    {
      const double dx = u - c.x;
      const double dy = v - c.y;
      const double x = dx * std::cos(c.angle) + dy * std::sin(c.angle);
      const double y = -dx * std::sin(c.angle) + dy * std::cos(c.angle);
      if ((x * x) / (a * a) + (y * y) / (b * b) > 1.0)
        continue;
      const double value = img.at<float>(v, u);
      sum += value;
      max_seen = std::max(max_seen, value);
      above += value > threshold ? 1 : 0;
      ++count;
    }
  if (max_value)
    *max_value = max_seen;
  if (fraction_above)
    *fraction_above = count ? static_cast<double>(above) / count : 0.0;
  return count ? sum / count : 0.0;
}

}  // namespace

TEST(SpoolRenderer, EllipseTruthMatchesProjectedRim)
{
  // r_vertical and the centre come from the conic; check them against projected 3D points.
  const sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(640, 480);
  const sv::SpoolRenderer renderer(k);
  const sv::CameraPose p = pose(0.7, 0.12, 8 * kDeg, 3 * kDeg, 0.05);
  const sv::GroundTruth gt = renderer.groundTruth(cleanScene(), p);
  ASSERT_TRUE(gt.flange.has_value());
  // Project the rim by hand with the same pose convention as the header documents.
  const double planar = std::sqrt(p.distance * p.distance - p.height * p.height - p.lateral * p.lateral);
  const cv::Vec3d eye(p.lateral, 1.0 + p.height, -planar);
  const cv::Vec3d fwd(std::sin(p.yaw) * std::cos(p.pitch), -std::sin(p.pitch), std::cos(p.yaw) * std::cos(p.pitch));
  const cv::Vec3d right(std::cos(p.yaw), 0.0, -std::sin(p.yaw));
  const cv::Vec3d down = right.cross(fwd);
  double v_min = 1e9;
  double v_max = -1e9;
  for (int i = 0; i < 20000; ++i)
  {
    const double a = 2 * M_PI * i / 20000;
    const cv::Vec3d w = cv::Vec3d(0.175 * std::cos(a), 1.0 + 0.175 * std::sin(a), 0.0) - eye;
    const double z = w.dot(fwd);
    const double v = k.fy * w.dot(down) / z + k.cy;
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
  }
  EXPECT_NEAR(gt.flange->r_vertical, 0.5 * (v_max - v_min), 1e-3);
  EXPECT_NEAR(gt.flange->y, 0.5 * (v_max + v_min), 0.05);  // the centre lies mid-extent
  const cv::Vec3d c = cv::Vec3d(0.0, 1.0, 0.0) - eye;
  EXPECT_NEAR(gt.flange->centre_x, k.fx * c.dot(right) / c.dot(fwd) + k.cx, 1e-9);
  EXPECT_NEAR(gt.distance, c.dot(fwd), 1e-12);
  EXPECT_NEAR(gt.range, 0.7, 1e-12);
  // Under yaw the ellipse centre is displaced from the projected 3D centre (towards the
  // nearer side); the hole, being small, barely moves.
  EXPECT_GT(std::abs(gt.flange->x - gt.flange->centre_x), 2.0);
  EXPECT_LT(std::abs(gt.hole->x - gt.hole->centre_x), 0.2);
}

TEST(SpoolRenderer, RimsFallOnRenderedEdges)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  for (const sv::CameraPose& p : {pose(0.8, 0.05, 3 * kDeg, 1 * kDeg), pose(1.05, -0.2, 6 * kDeg)})
  {
    const sv::RenderedFrame frame = renderer.render(cleanScene(), p);
    const cv::Mat img = grey(frame.image);
    ASSERT_TRUE(frame.truth.flange && frame.truth.hole);

    // Upper part of the flange rim: black flange inside, lit back wall outside. On the side
    // towards the camera the flange's cylindrical edge and the back flange widen the black
    // silhouette beyond the front rim, so only the far side is compared.
    const sv::ProjectedCircle& flange = *frame.truth.flange;
    int checked = 0;
    double sum_abs = 0.0;
    for (int i = 0; i < 180; ++i)
    {
      const double t = 2 * M_PI * i / 180;
      const cv::Point2d rim = ellipsePoint(flange, t);
      if (rim.y > flange.y - 0.3 * flange.r || (rim.x - flange.x) * p.lateral > 0.0)
        continue;
      const auto off = edgeOffset(img, flange, t, 4.0);
      if (!off)
        continue;
      EXPECT_LT(std::abs(*off), 0.6) << "flange rim, t = " << t;
      sum_abs += std::abs(*off);
      ++checked;
    }
    ASSERT_GT(checked, 25);
    EXPECT_LT(sum_abs / checked, 0.25);

    // Lower part of the hole's front rim: the bore wall inside is lighter than the flange.
    const sv::ProjectedCircle& hole = *frame.truth.hole;
    checked = 0;
    sum_abs = 0.0;
    for (int i = 0; i < 120; ++i)
    {
      const double t = 2 * M_PI * i / 120;
      if (ellipsePoint(hole, t).y < hole.y + 0.3 * hole.r)
        continue;
      const auto off = edgeOffset(img, hole, t, 2.5);
      ASSERT_TRUE(off.has_value()) << "hole rim, t = " << t;
      EXPECT_LT(std::abs(*off), 0.6) << "hole rim, t = " << t;
      sum_abs += std::abs(*off);
      ++checked;
    }
    ASSERT_GT(checked, 30);
    EXPECT_LT(sum_abs / checked, 0.3);
  }
}

TEST(SpoolRenderer, BoreShowsThroughOnlyNearTheAxis)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::SceneParams scene = cleanScene();

  // On the axis, 6 cm above it: a bright lens in the upper part of the hole.
  const sv::RenderedFrame near = renderer.render(scene, pose(0.55));
  ASSERT_TRUE(near.truth.hole);
  EXPECT_TRUE(near.truth.bore_visible);
  EXPECT_GT(near.truth.hole_lit_fraction, 0.15);
  EXPECT_LT(near.truth.hole_lit_fraction, 0.5);
  const cv::Mat img = grey(near.image);
  const sv::ProjectedCircle& hole = *near.truth.hole;
  double lit = 0.0;
  const double lens = bilinear(img, hole.x, hole.y - 0.8 * hole.r);
  meanInEllipse(img, hole, 1.0, nullptr, &lit, 0.6 * lens);
  EXPECT_NEAR(lit, near.truth.hole_lit_fraction, 0.06);
  // The lens is at the top: the camera above the axis looks down the bore.
  EXPECT_GT(lens, 3.0 * bilinear(img, hole.x, hole.y + 0.8 * hole.r));

  // Far off the axis nothing shows through, but the bore wall is still lighter than the flange.
  const sv::RenderedFrame off = renderer.render(scene, pose(0.9, 0.25));
  ASSERT_TRUE(off.truth.hole);
  EXPECT_FALSE(off.truth.bore_visible);
  EXPECT_EQ(off.truth.hole_lit_fraction, 0.0);
  const cv::Mat img2 = grey(off.image);
  double max_hole = 0.0;
  const double hole_mean = meanInEllipse(img2, *off.truth.hole, 1.5, &max_hole);
  sv::ProjectedCircle ring = *off.truth.hole;  // a band of flange around the hole
  ring.semi_major *= 2.5;
  ring.semi_minor *= 2.5;
  const double ring_and_hole = meanInEllipse(img2, ring, 0.0);
  const double flange_mean = (ring_and_hole * 6.25 - hole_mean) / 5.25;  // areas 6.25 : 1
  EXPECT_GT(hole_mean, flange_mean + 4.0);
  const sv::ProjectedCircle& flange = *off.truth.flange;
  const double wall = bilinear(img2, flange.x, flange.y - flange.r_vertical - 15.0);
  EXPECT_LT(max_hole, 0.5 * wall);
}

TEST(SpoolRenderer, YawDistanceAndAlignmentTruth)
{
  const sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(160, 120);
  const sv::SpoolRenderer renderer(k);
  const sv::SceneParams scene = cleanScene();

  // Camera 10 cm right of the spool, looking straight ahead: the spool appears left.
  const sv::GroundTruth right = renderer.groundTruth(scene, pose(0.9, 0.1));
  const double depth = std::sqrt(0.81 - 0.0036 - 0.01);
  EXPECT_NEAR(right.yaw, std::atan(-0.1 / depth), 1e-12);
  EXPECT_LT(right.yaw, 0.0);
  EXPECT_NEAR(right.distance, depth, 1e-12);
  EXPECT_NEAR(right.range, 0.9, 1e-12);
  EXPECT_NEAR(right.lateral_offset, -0.1, 1e-12);  // = depth * tan(yaw), Eq. 3.8
  EXPECT_NEAR(right.reference.y, k.cy + k.fy * 0.06 / depth, 1e-9);
  EXPECT_NEAR(right.flange->r_vertical, k.fy * 0.175 / depth, 1e-6);
  EXPECT_NEAR(right.puller_miss, 0.1, 1e-12);
  EXPECT_FALSE(right.puller_clears);
  EXPECT_FALSE(right.aligned);

  const sv::GroundTruth aligned = renderer.groundTruth(scene, pose(0.55));
  EXPECT_TRUE(aligned.puller_clears);
  EXPECT_TRUE(aligned.aligned);
  EXPECT_NEAR(aligned.puller_miss, 0.0, 1e-12);
  EXPECT_NEAR(aligned.yaw, 0.0, 1e-12);
  EXPECT_NEAR(aligned.hole->centre_y, aligned.reference.y, 1e-9);

  const sv::GroundTruth far = renderer.groundTruth(scene, pose(0.7));
  EXPECT_TRUE(far.puller_clears);
  EXPECT_FALSE(far.aligned);                                                       // too far
  EXPECT_FALSE(renderer.groundTruth(scene, pose(0.55, 0.004)).aligned);            // misses by 4 mm
  EXPECT_TRUE(renderer.groundTruth(scene, pose(0.55, 0.002)).aligned);             // within t_f
  EXPECT_FALSE(renderer.groundTruth(scene, pose(0.55, 0.0, 0.5 * kDeg)).aligned);  // askew: 4.8 mm off at the face

  EXPECT_THROW(renderer.groundTruth(scene, pose(0.05, 0.1)), std::invalid_argument);
}

TEST(SpoolRenderer, DepthRangeAndAxisOnAYawedOffsetPose)
{
  // Camera 10 cm right of the axis, 6 cm above, turned 10 deg right: by hand, the face centre
  // seen from the camera is w = (-0.1, -0.06, planar) in the world (x right, y up, z into the
  // shelf); the camera's right is (cos a, 0, -sin a), down (0, -1, 0), forward (sin a, 0, cos a).
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const double a = 10.0 * kDeg;
  const sv::GroundTruth gt = renderer.groundTruth(cleanScene(), pose(0.8, 0.1, a));
  const double planar = std::sqrt(0.64 - 0.0036 - 0.01);
  const double x = -0.1 * std::cos(a) - planar * std::sin(a);
  const double z = -0.1 * std::sin(a) + planar * std::cos(a);
  EXPECT_NEAR(gt.position.x, x, 1e-12);
  EXPECT_NEAR(gt.position.y, 0.06, 1e-12);
  EXPECT_NEAR(gt.position.z, z, 1e-12);
  EXPECT_NEAR(gt.distance, z, 1e-12);  // depth, about 0.8% short of the range here
  EXPECT_NEAR(gt.range, 0.8, 1e-12);
  EXPECT_GT(gt.range - gt.distance, 0.005);
  EXPECT_NEAR(gt.lateral_offset, x, 1e-12);
  EXPECT_NEAR(gt.yaw, std::atan(x / z), 1e-12);
  // The spool axis (world +z) in the camera frame, and its angles.
  EXPECT_NEAR(gt.axis[0], -std::sin(a), 1e-12);
  EXPECT_NEAR(gt.axis[1], 0.0, 1e-12);
  EXPECT_NEAR(gt.axis[2], std::cos(a), 1e-12);
  EXPECT_NEAR(gt.axis_angle, a, 1e-12);
  EXPECT_NEAR(gt.axis_yaw, -a, 1e-12);
  // The puller axis, through (0, 0.06, 0) along z, meets the face plane (world z = 0) at
  // x = 0.1 + planar tan(a) in the world.
  EXPECT_NEAR(gt.puller_miss, 0.1 + planar * std::tan(a), 1e-9);

  const nlohmann::ordered_json json = sv::groundTruthJson(gt);
  EXPECT_TRUE(json["range"].is_number()) << json;
  EXPECT_TRUE(json["position"]["x"].is_number()) << json;
  EXPECT_TRUE(json["axis"]["x"].is_number()) << json;
  EXPECT_TRUE(json["axis_yaw"].is_number()) << json;
  EXPECT_TRUE(json["puller_clearance"].is_number()) << json;
  EXPECT_EQ(json["puller_clears"], false);
  EXPECT_EQ(json["camera"]["distortion"], nlohmann::ordered_json::array());
}

TEST(SpoolRenderer, ThePullerClearsOnlyWithinTheClearanceAtBothEndsOfTheBore)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::SceneParams scene = cleanScene();  // bore 20 cm, t_f = 2.5 mm
  // Heading `a` with the puller axis through the face centre: it misses the bore axis by
  // bore_length tan(a) at the back end (0.2 tan(0.5 deg) = 1.7 mm, 0.2 tan(1 deg) = 3.5 mm).
  auto throughTheFaceCentre = [&](double a)
  {
    const double planar = 0.55;
    const double lateral = -planar * std::tan(a);
    return renderer.groundTruth(scene, pose(std::sqrt(planar * planar + 0.06 * 0.06 + lateral * lateral), lateral, a));
  };
  const sv::GroundTruth half_degree = throughTheFaceCentre(0.5 * kDeg);
  EXPECT_NEAR(half_degree.puller_miss, 0.0, 1e-12);
  EXPECT_NEAR(half_degree.puller_clearance, 0.0025 - 0.2 * std::tan(0.5 * kDeg), 1e-5);  // the back end decides
  EXPECT_TRUE(half_degree.puller_clears);
  EXPECT_TRUE(half_degree.aligned);
  const sv::GroundTruth one_degree = throughTheFaceCentre(1.0 * kDeg);
  EXPECT_NEAR(one_degree.puller_miss, 0.0, 1e-12);
  EXPECT_NEAR(one_degree.axis_angle, 1.0 * kDeg, 1e-12);
  EXPECT_FALSE(one_degree.puller_clears);
  EXPECT_FALSE(one_degree.aligned);

  // Parallel axes: the lateral or vertical miss alone decides.
  EXPECT_TRUE(renderer.groundTruth(scene, pose(0.55, 0.0024)).puller_clears);
  EXPECT_NEAR(renderer.groundTruth(scene, pose(0.55, 0.0024)).puller_clearance, 0.0001, 1e-6);
  EXPECT_FALSE(renderer.groundTruth(scene, pose(0.55, 0.0026)).puller_clears);
  EXPECT_TRUE(renderer.groundTruth(scene, pose(0.55, 0.0, 0.0, 0.0, 0.0624)).puller_clears);
  EXPECT_FALSE(renderer.groundTruth(scene, pose(0.55, 0.0, 0.0, 0.0, 0.0626)).puller_clears);
  // A wider bore gives more room.
  sv::SceneParams wide = scene;
  wide.hole_diameter = 0.04;
  EXPECT_TRUE(renderer.groundTruth(wide, pose(0.55, 0.0044)).puller_clears);

  // aligned: puller_clears in the insertion window, 0.5-0.6 m of depth (not range).
  EXPECT_TRUE(renderer.groundTruth(scene, pose(std::hypot(0.599, 0.06))).aligned);
  EXPECT_FALSE(renderer.groundTruth(scene, pose(std::hypot(0.601, 0.06))).aligned);
  EXPECT_FALSE(renderer.groundTruth(scene, pose(std::hypot(0.499, 0.06))).aligned);
}

namespace
{
// A C270-like lens on a 640x480 camera (plumb_bob), principal point off centre.
sv::CameraIntrinsics c270()
{
  sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(640, 480);
  k.cx = 313.1;
  k.cy = 243.3;
  k.distortion = {-0.2, 0.05, 0.001, -0.0005, 0.0};
  return k;
}
}  // namespace

TEST(SpoolRenderer, DistortedTruthIsWhereTheLensPutsIt)
{
  // The camera on the spool axis, turned so that the spool lies near the top-left corner, where
  // the lens moves it by several pixels: the bore is seen end-on, a lit disc in the black face.
  const sv::CameraIntrinsics k = c270();
  sv::CameraIntrinsics pinhole = k;
  pinhole.distortion.clear();
  const sv::CameraPose p = pose(0.7, 0.0, 15 * kDeg, -10 * kDeg, 0.0);
  const sv::RenderedFrame frame = sv::SpoolRenderer(k).render(cleanScene(), p);
  const sv::GroundTruth undistorted = sv::SpoolRenderer(pinhole).groundTruth(cleanScene(), p);
  const sv::ProjectedCircle& hole = *frame.truth.hole;
  ASSERT_TRUE(frame.truth.bore_visible);
  EXPECT_GT(std::hypot(hole.x - undistorted.hole->x, hole.y - undistorted.hole->y), 4.0);
  // Sizes are those of the undistorted projection; the 3D truth does not depend on the lens.
  EXPECT_DOUBLE_EQ(hole.r, undistorted.hole->r);
  EXPECT_DOUBLE_EQ(frame.truth.distance, undistorted.distance);

  // The truth centre undistorted is the pinhole projection of the 3D centre.
  std::vector<cv::Point2d> undistorted_centre;
  cv::undistortPoints(std::vector<cv::Point2d>{{hole.centre_x, hole.centre_y}}, undistorted_centre,
                      cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1), k.distortion, cv::noArray(),
                      cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  EXPECT_NEAR(undistorted_centre[0].x, undistorted.hole->centre_x, 1e-6);
  EXPECT_NEAR(undistorted_centre[0].y, undistorted.hole->centre_y, 1e-6);

  // The lit disc's centroid in the rendered image (pixels weighted by how far they are from the
  // face's black towards the wall's grey, so edge pixels count by their coverage).
  const cv::Mat img = grey(frame.image);
  const double face = bilinear(img, hole.x + 2.5 * hole.r, hole.y);
  const double wall = bilinear(img, hole.x, hole.y);
  double sum = 0.0;
  cv::Point2d centroid(0.0, 0.0);
  for (int v = static_cast<int>(hole.y - 2 * hole.r); v <= hole.y + 2 * hole.r; ++v)
    for (int u = static_cast<int>(hole.x - 2 * hole.r); u <= hole.x + 2 * hole.r; ++u)
    {
      const double w = std::clamp((img.at<float>(v, u) - face) / (wall - face), 0.0, 1.0);
      sum += w;
      centroid += w * cv::Point2d(u, v);
    }
  centroid /= sum;
  EXPECT_NEAR(centroid.x, hole.x, 0.15);
  EXPECT_NEAR(centroid.y, hole.y, 0.15);

  // Barrel distortion pulls a rim cut by the image border back into view.
  const sv::CameraPose edge = pose(0.8, -0.35);
  const double seen = sv::SpoolRenderer(k).groundTruth(cleanScene(), edge).flange->visible_fraction;
  const double seen_pinhole = sv::SpoolRenderer(pinhole).groundTruth(cleanScene(), edge).flange->visible_fraction;
  EXPECT_GT(seen, seen_pinhole + 0.02);  // 0.40 vs 0.36
  EXPECT_EQ(sv::groundTruthJson(frame.truth)["camera"]["distortion"],
            nlohmann::ordered_json({-0.2, 0.05, 0.001, -0.0005, 0.0}));
}

TEST(SpoolRenderer, DeterministicFromSeed)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(160, 120));
  const sv::SceneParams scene = sv::randomScene(sv::SceneKind::kSpool, 42);
  const sv::CameraPose p = pose(0.75, -0.05, 2 * kDeg);
  const cv::Mat a = renderer.render(scene, p).image;
  const cv::Mat b = renderer.render(sv::randomScene(sv::SceneKind::kSpool, 42), p).image;
  EXPECT_EQ(a.type(), CV_8UC3);
  EXPECT_EQ(a.size(), cv::Size(160, 120));
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_EQ(sv::groundTruthJson(renderer.groundTruth(scene, p)).dump(),
            sv::groundTruthJson(renderer.groundTruth(sv::randomScene(sv::SceneKind::kSpool, 42), p)).dump());

  sv::SceneParams noise_only = scene;
  noise_only.seed = 43;  // same shelf, other sensor noise
  noise_only.noise_sigma = 3.0;
  sv::SceneParams noisy = scene;
  noisy.noise_sigma = 3.0;
  EXPECT_GT(cv::norm(renderer.render(noisy, p).image, renderer.render(noise_only, p).image, cv::NORM_L1), 0.0);
  EXPECT_GT(cv::norm(a, renderer.render(sv::randomScene(sv::SceneKind::kSpool, 44), p).image, cv::NORM_L1), 0.0);
}

TEST(SpoolRenderer, NegativesHaveNoFlangeTruth)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(160, 120));
  for (sv::SceneKind kind :
       {sv::SceneKind::kEmptySlot, sv::SceneKind::kPlate, sv::SceneKind::kTapeRoll, sv::SceneKind::kCan})
  {
    const sv::SceneParams scene = sv::randomScene(kind, 7);
    const sv::RenderedFrame frame = renderer.render(scene, pose(0.8));
    EXPECT_FALSE(frame.truth.flange.has_value()) << sv::toString(kind);
    EXPECT_FALSE(frame.truth.hole.has_value());
    EXPECT_TRUE(std::isnan(frame.truth.distance));
    EXPECT_TRUE(std::isnan(frame.truth.yaw));
    EXPECT_FALSE(frame.truth.aligned);
    EXPECT_FALSE(frame.truth.bore_visible);
    const nlohmann::ordered_json json = sv::groundTruthJson(frame.truth);
    EXPECT_TRUE(json["flange"].is_null()) << json;
    EXPECT_TRUE(json["distance"].is_null()) << json;
  }
}

TEST(SpoolRenderer, ObjectsAndNeighboursAppear)
{
  const sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(320, 240);
  const sv::SpoolRenderer renderer(k);
  sv::SceneParams empty = cleanScene();
  empty.kind = sv::SceneKind::kEmptySlot;
  sv::SceneParams plate = empty;
  plate.kind = sv::SceneKind::kPlate;
  plate.object_colour = cv::Vec3d(0.05, 0.05, 0.05);  // a black plate: a flange look-alike
  const sv::CameraPose p = pose(0.8);
  const cv::Mat a = grey(renderer.render(empty, p).image);
  const cv::Mat b = grey(renderer.render(plate, p).image);
  // The plate stands on the board below the hole axis, in the middle column.
  const double board_top_v = k.cy + k.fy * (0.06 + 0.175) / std::sqrt(0.64 - 0.0036);
  const int v = static_cast<int>(board_top_v - k.fy * plate.object_radius / 0.8);
  EXPECT_GT(a.at<float>(v, 160), 4.0 * b.at<float>(v, 160));

  sv::SceneParams shelf = cleanScene();
  shelf.neighbours = {{-1, 0.02, 0.0}, {1, 0.05, 0.01}};
  const sv::GroundTruth gt = renderer.groundTruth(shelf, pose(1.1));
  ASSERT_EQ(gt.neighbours.size(), 2u);
  const double depth = std::sqrt(1.21 - 0.0036);
  EXPECT_NEAR(gt.neighbours[0].flange.centre_x, k.cx - k.fx * 0.37 / depth, 1e-6);
  EXPECT_NEAR(gt.neighbours[1].flange.centre_x, k.cx + k.fx * 0.40 / (depth + 0.01), 1e-6);
  EXPECT_NEAR(gt.neighbours[0].yaw, std::atan(-0.37 / depth), 1e-9);
  EXPECT_NEAR(gt.neighbours[1].distance, depth + 0.01, 1e-9);  // depth, set back 1 cm
  EXPECT_TRUE(gt.spool_centre_in_view);
}

namespace
{
// FNV-1a over the image bytes.
std::uint64_t checksum(const cv::Mat& image)
{
  std::uint64_t h = 1469598103934665603ULL;
  const cv::Mat bytes = image.isContinuous() ? image : image.clone();
  for (std::size_t i = 0; i < bytes.total() * bytes.elemSize(); ++i)
    h = (h ^ bytes.data[i]) * 1099511628211ULL;
  return h;
}
}  // namespace

TEST(SpoolRenderer, OldScenesRenderAsBefore)
{
  // The main, approach and negatives sets are pinned by other tests and by recorded results:
  // new realism knobs must default to the old look. Checksums recorded when those sets took a
  // webcam's gamma (0.4-0.5; linear before, which hid the dark-side shift of blurred edges).
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(320, 240));
  const cv::Mat spool = renderer.render(sv::randomScene(sv::SceneKind::kSpool, 1000020), pose(0.7, -0.1, 0.03)).image;
  const cv::Mat can = renderer.render(sv::randomScene(sv::SceneKind::kCan, 77), pose(0.9, 0.05)).image;
  EXPECT_EQ(checksum(spool), 12372908659662771060ULL);
  EXPECT_EQ(checksum(can), 9140184316742674502ULL);
}

namespace
{
// The hard set's camera without the random parts: auto exposure to mid grey through a webcam
// gamma, a bore lit only through its openings.
sv::SceneParams webcamScene()
{
  sv::SceneParams s = cleanScene();
  s.auto_exposure_target = 0.45;
  s.gamma = 0.45;
  s.bore_falloff = 0.01;
  return s;
}

// The camera `distance` m from the face centre on a line `off_axis` rad right of the spool axis,
// `height` m above it, looking at the face centre.
sv::CameraPose offAxisPose(double distance, double off_axis, double height)
{
  const double lateral = distance * std::sin(off_axis);
  const double planar = std::sqrt(distance * distance - lateral * lateral - height * height);
  return pose(distance, lateral, -std::atan2(lateral, planar), std::atan2(height, planar), height);
}

// Mean grey of the annulus between `inner` and `outer` times the circle's semi-axes.
double meanInAnnulus(const cv::Mat& img, const sv::ProjectedCircle& c, double inner, double outer)
{
  sv::ProjectedCircle big = c;
  big.semi_major *= outer;
  big.semi_minor *= outer;
  sv::ProjectedCircle small = c;
  small.semi_major *= inner;
  small.semi_minor *= inner;
  const double a_big = outer * outer;
  const double a_small = inner * inner;
  return (meanInEllipse(img, big, 0.0) * a_big - meanInEllipse(img, small, 0.0) * a_small) / (a_big - a_small);
}
}  // namespace

TEST(SpoolRenderer, HardSceneKeepsTheShelfAndAddsTheWebcam)
{
  const sv::SceneParams main = sv::randomScene(sv::SceneKind::kSpool, 5);
  const sv::SceneParams hard = sv::randomHardScene(sv::SceneKind::kSpool, 5);
  EXPECT_EQ(hard.bore_length, main.bore_length);
  EXPECT_EQ(hard.neighbours.size(), main.neighbours.size());
  EXPECT_GT(hard.auto_exposure_target, 0.0);
  EXPECT_GT(hard.bore_falloff, 0.0);
  EXPECT_LT(hard.gamma, 1.0);
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(320, 240));
  const sv::CameraPose p = pose(0.8, 0.05, -2 * kDeg);
  const cv::Mat a = renderer.render(main, p).image;
  const cv::Mat b = renderer.render(hard, p).image;
  EXPECT_GT(cv::norm(a, b, cv::NORM_L1) / (a.total() * a.channels()), 10.0);
  // Deterministic: same seed, same frame; another seed, another frame.
  EXPECT_EQ(cv::norm(b, renderer.render(sv::randomHardScene(sv::SceneKind::kSpool, 5), p).image, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(b, renderer.render(sv::randomHardScene(sv::SceneKind::kSpool, 6), p).image, cv::NORM_L1), 0.0);

  // Clutter boxes stand at or behind the face plane and beside the target's flange, so they
  // never hide its face centre.
  for (std::uint64_t seed = 1; seed <= 200; ++seed)
    for (const sv::ShelfBox& box : sv::randomHardScene(sv::SceneKind::kSpool, seed).boxes)
    {
      EXPECT_GE(box.z, 0.0);
      if (!box.upper)
      {
        EXPECT_GE(std::abs(box.x) - 0.5 * box.width, 0.175);
      }
    }
}

TEST(SpoolRenderer, AutoExposureLiftsABlackFaceToMidGrey)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(320, 240));
  sv::SceneParams fixed = cleanScene();
  fixed.wall_colour = cv::Vec3d(0.15, 0.15, 0.15);  // a dark wall: the face dominates the metering
  sv::SceneParams automatic = webcamScene();
  automatic.wall_colour = fixed.wall_colour;
  const sv::CameraPose p = pose(0.6);
  const sv::RenderedFrame dark = renderer.render(fixed, p);
  const sv::RenderedFrame lifted = renderer.render(automatic, p);
  const sv::ProjectedCircle& hole = *dark.truth.hole;
  const double face_fixed = meanInAnnulus(grey(dark.image), hole, 3.0, 6.0);
  const double face_auto = meanInAnnulus(grey(lifted.image), hole, 3.0, 6.0);
  EXPECT_LT(face_fixed, 30.0);
  EXPECT_GT(face_auto, 90.0);
  EXPECT_LT(face_auto, 160.0);
}

TEST(SpoolRenderer, OffAxisTheBoreIsDarkerThanTheFace)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::RenderedFrame frame = renderer.render(webcamScene(), offAxisPose(0.7, 12 * kDeg, 0.02));
  ASSERT_TRUE(frame.truth.hole);
  // "In view but dark": the detector is scored on finding this front rim.
  EXPECT_TRUE(frame.truth.hole_in_view);
  EXPECT_FALSE(frame.truth.bore_visible);
  EXPECT_TRUE(std::isnan(frame.truth.hole_lens.x));
  const cv::Mat img = grey(frame.image);
  const sv::ProjectedCircle& hole = *frame.truth.hole;
  const double bore = meanInEllipse(img, hole, 1.5);
  const double face = meanInAnnulus(img, hole, 1.5, 2.5);
  EXPECT_LT(bore, face - 30.0) << "bore " << bore << ", face " << face;

  // The old bore (lit from the back all along) is lighter than the face: the kind renderer.
  sv::SceneParams kind = webcamScene();
  kind.bore_falloff = 0.0;
  const cv::Mat kind_img = grey(renderer.render(kind, offAxisPose(0.7, 12 * kDeg, 0.02)).image);
  EXPECT_GT(meanInEllipse(kind_img, hole, 1.5), meanInAnnulus(kind_img, hole, 1.5, 2.5));
}

TEST(SpoolRenderer, NearTheAxisOnlyTheParallaxLensIsBright)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::RenderedFrame frame = renderer.render(webcamScene(), pose(0.55));  // 6 cm above the axis
  ASSERT_TRUE(frame.truth.hole);
  ASSERT_TRUE(frame.truth.bore_visible);
  const cv::Mat img = grey(frame.image);
  const sv::ProjectedCircle& hole = *frame.truth.hole;
  const double face = meanInAnnulus(img, hole, 1.5, 2.5);
  // Bright pixels inside the front rim: the wall seen through both openings.
  double sum_u = 0.0;
  double sum_v = 0.0;
  int bright = 0;
  int inside = 0;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u)
    {
      if (std::hypot(u - hole.x, v - hole.y) > hole.r)
        continue;
      ++inside;
      if (img.at<float>(v, u) < face + 40.0)
        continue;
      sum_u += u;
      sum_v += v;
      ++bright;
    }
  ASSERT_GT(bright, 20);
  const cv::Point2d lens(sum_u / bright, sum_v / bright);
  EXPECT_LT(lens.y, hole.y - 0.3 * hole.r);  // above the rim's centre: the camera looks down
  EXPECT_LT(bright, 0.5 * inside);           // smaller than the opening
  EXPECT_NEAR(static_cast<double>(bright) / inside, frame.truth.hole_lit_fraction, 0.08);
  EXPECT_NEAR(lens.x, frame.truth.hole_lens.x, 1.0);
  EXPECT_NEAR(lens.y, frame.truth.hole_lens.y, 1.5);
  // The rest of the opening is the dark bore: darker than the face.
  EXPECT_LT(bilinear(img, hole.x, hole.y + 0.7 * hole.r), face - 20.0);
}

TEST(SpoolRenderer, RaisedRibsShowBrightAndDarkRings)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  sv::SceneParams flat = webcamScene();
  flat.ribs = true;
  sv::SceneParams raised = flat;
  raised.rib_slope = 0.7;
  const sv::CameraPose p = pose(0.7);
  const cv::Mat a = grey(renderer.render(flat, p).image);
  const cv::Mat b = grey(renderer.render(raised, p).image);
  const sv::ProjectedCircle hole = *renderer.groundTruth(flat, p).hole;
  // Down the column above the axis, over the 11.5 cm rib and the bare face beside it.
  const double px_per_m = hole.r / 0.018;
  double flat_min = 255.0;
  double flat_max = 0.0;
  double raised_min = 255.0;
  double raised_max = 0.0;
  for (double r = 0.100; r <= 0.130; r += 0.2 / px_per_m)
  {
    const double v = hole.y - r * px_per_m;
    flat_min = std::min(flat_min, bilinear(a, hole.x, v));
    flat_max = std::max(flat_max, bilinear(a, hole.x, v));
    raised_min = std::min(raised_min, bilinear(b, hole.x, v));
    raised_max = std::max(raised_max, bilinear(b, hole.x, v));
  }
  EXPECT_LT(flat_max - flat_min, 12.0);
  EXPECT_GT(raised_max - raised_min, 30.0);
}

TEST(SpoolRenderer, GlossyFaceShowsALampStreak)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(320, 240));
  sv::SceneParams glossy = cleanScene();
  glossy.gloss = 0.4;
  glossy.gloss_lamp = cv::Vec3d(0.0, 1.0, -1.0);  // level with the axis: a horizontal streak
  const sv::CameraPose p = pose(0.8, 0.0, 0.0, 0.0, 0.0);
  const cv::Mat matte = grey(renderer.render(cleanScene(), p).image);
  const cv::Mat shiny = grey(renderer.render(glossy, p).image);
  const sv::ProjectedCircle flange = *renderer.groundTruth(glossy, p).flange;
  // The streak crosses the face beside the hole, and leaves the face's top alone.
  const double u = flange.x + 0.5 * flange.r;
  EXPECT_GT(bilinear(shiny, u, flange.y) - bilinear(matte, u, flange.y), 40.0);
  EXPECT_LT(std::abs(bilinear(shiny, u, flange.y - 0.8 * flange.r) - bilinear(matte, u, flange.y - 0.8 * flange.r)),
            3.0);
}

TEST(SpoolRenderer, PullerRodOccupiesTheBottomCentre)
{
  const sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(320, 240);
  const sv::SpoolRenderer renderer(k);
  sv::SceneParams rod = cleanScene();
  rod.puller_rod_length = 0.25;
  const sv::CameraPose p = pose(0.8);
  const sv::RenderedFrame without = renderer.render(cleanScene(), p);
  const sv::RenderedFrame with = renderer.render(rod, p);
  const cv::Mat a = grey(without.image);
  const cv::Mat b = grey(with.image);
  const int u = static_cast<int>(k.cx);
  // Bottom centre: the neutral grey steel instead of the coloured shelf board.
  const cv::Vec3b board = without.image.at<cv::Vec3b>(k.height - 2, u);
  const cv::Vec3b steel = with.image.at<cv::Vec3b>(k.height - 2, u);
  EXPECT_GT(std::abs(board[0] - board[2]), 20);
  EXPECT_LT(std::abs(steel[0] - steel[2]), 3);
  EXPECT_GT(std::abs(b.at<float>(k.height - 2, u) - a.at<float>(k.height - 2, u)), 10.0);
  // Its tip's top edge: fy * (6 cm - radius) / 25 cm below the principal point; above it and
  // in the bottom corners nothing changes.
  const double tip_v = k.cy + k.fy * (0.06 - 0.0155) / 0.25;
  EXPECT_EQ(b.at<float>(static_cast<int>(tip_v) - 3, u), a.at<float>(static_cast<int>(tip_v) - 3, u));
  EXPECT_GT(std::abs(b.at<float>(static_cast<int>(tip_v) + 3, u) - a.at<float>(static_cast<int>(tip_v) + 3, u)), 5.0);
  EXPECT_EQ(b.at<float>(k.height - 2, 2), a.at<float>(k.height - 2, 2));
  EXPECT_FALSE(with.truth.hole_occluded);
  EXPECT_TRUE(with.truth.hole_in_view);

  // Long enough to cover the bore's line of sight, the rod hides the hole.
  rod.puller_rod_length = 0.6;
  const sv::GroundTruth hidden = renderer.groundTruth(rod, pose(0.7));
  EXPECT_TRUE(hidden.hole_occluded);
  EXPECT_FALSE(hidden.hole_in_view);
  EXPECT_EQ(sv::groundTruthJson(hidden)["hole_occluded"], true);
}

TEST(SpoolRenderer, PrincipalPointOffTheImageCentre)
{
  // Moving the principal point moves the picture with it, pixel for pixel, and the truth too.
  const sv::CameraIntrinsics centred = sv::CameraIntrinsics::thesisDefault(320, 240);
  sv::CameraIntrinsics shifted = centred;
  shifted.cx += 7.0;
  shifted.cy -= 5.0;
  const sv::CameraPose p = pose(0.75, 0.03, 1 * kDeg);
  const sv::RenderedFrame a = sv::SpoolRenderer(centred).render(cleanScene(), p);
  const sv::RenderedFrame b = sv::SpoolRenderer(shifted).render(cleanScene(), p);
  const cv::Rect inner(10, 10, 300, 220);
  EXPECT_EQ(cv::norm(a.image(inner), b.image(inner + cv::Point(7, -5)), cv::NORM_INF), 0.0);
  EXPECT_NEAR(b.truth.hole->x - a.truth.hole->x, 7.0, 1e-9);
  EXPECT_NEAR(b.truth.flange->y - a.truth.flange->y, -5.0, 1e-9);
  EXPECT_NEAR(b.truth.reference.x, shifted.cx, 1e-12);
}

TEST(WallPrint, EachKindIsDeterministicBusyAndFiltersToItsOwnMean)
{
  for (int k = 0; k < 5; ++k)
  {
    sv::WallPrint print;
    print.kind = static_cast<sv::PrintKind>(k);
    print.x = 0.3;
    print.y = 1.2;
    print.width = 0.6;
    print.height = 0.4;
    print.seed = 17;
    const sv::PrintTexture texture(print);
    EXPECT_TRUE(texture.contains(0.01, 1.01));
    EXPECT_FALSE(texture.contains(-0.01, 1.2));
    EXPECT_FALSE(texture.contains(0.3, 1.41));

    // Sampled at the finest level on a 1 cm grid: paper-to-ink reflectances and many edges.
    double sum = 0.0;
    int steps = 0;
    int samples = 0;
    double lo = 1.0;
    double hi = 0.0;
    double previous = -1.0;
    for (double y = 1.005; y < 1.4; y += 0.01)
      for (double x = 0.005; x < 0.6; x += 0.01)
      {
        const cv::Vec3d r = texture.reflectance(x, y, 0.0);
        const double g = (r[0] + r[1] + r[2]) / 3.0;
        ASSERT_GE(g, 0.03 - 1e-6);
        ASSERT_LE(g, 0.85 + 1e-6);
        lo = std::min(lo, g);
        hi = std::max(hi, g);
        steps += previous >= 0.0 && std::abs(g - previous) > 0.05 ? 1 : 0;
        previous = g;
        sum += g;
        ++samples;
      }
    EXPECT_GT(hi - lo, 0.3) << k;
    EXPECT_GT(steps, 30) << k;  // far busier than the plain wall's 5% pattern
    // A pixel 16 cm wide on the wall sees the print's mean, not one texel of it.
    const cv::Vec3d coarse = texture.reflectance(0.3, 1.2, 0.16);
    EXPECT_NEAR((coarse[0] + coarse[1] + coarse[2]) / 3.0, sum / samples, 0.12) << k;
    // The same seed draws the same print; another seed another.
    EXPECT_EQ(sv::PrintTexture(print).reflectance(0.123, 1.234, 0.0), texture.reflectance(0.123, 1.234, 0.0));
    print.seed = 18;
    const sv::PrintTexture other(print);
    double differ = 0.0;
    for (double x = 0.005; x < 0.6; x += 0.01)
      differ += cv::norm(other.reflectance(x, 1.2, 0.0) - texture.reflectance(x, 1.2, 0.0));
    EXPECT_GT(differ, 0.1) << k;
  }
}

TEST(WallPrint, IsSeenOnTheWallWhereItHangsAndChangesNothingElse)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(320, 240));
  sv::SceneParams plain = cleanScene();
  sv::SceneParams printed = plain;
  sv::WallPrint print;
  print.kind = sv::PrintKind::kCartons;
  print.x = 0.45;  // right of the flange, on the wall between the boards
  print.y = 1.0;
  print.width = 0.3;
  print.height = 0.3;
  printed.wall_prints.push_back(print);
  const sv::CameraPose p = pose(0.9);
  const sv::RenderedFrame a = renderer.render(plain, p);
  const sv::RenderedFrame b = renderer.render(printed, p);
  EXPECT_EQ(sv::groundTruthJson(a.truth).dump(), sv::groundTruthJson(b.truth).dump());
  cv::Mat diff;
  cv::absdiff(a.image, b.image, diff);
  cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
  const cv::Rect changed = cv::boundingRect(diff > 2);
  ASSERT_GT(changed.area(), 0);
  // Where the print's corners project: the wall is 0.3 m behind the face (bore_length + wall_gap).
  const sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(320, 240);
  const double z = p.distance + plain.bore_length + plain.wall_gap;
  const double left = k.cx + k.fx * (print.x - 0.5 * print.width) / z;
  const double right = k.cx + k.fx * (print.x + 0.5 * print.width) / z;
  EXPECT_GE(changed.x, left - 2.0);
  EXPECT_LE(changed.x + changed.width, right + 2.0);
  EXPECT_GT(changed.width, 0.5 * (right - left));  // the board hides none of it, the spool some

  // A mural over the whole wall: what shows through the bore is still the plain wall.
  print.kind = sv::PrintKind::kPhotograph;
  print.x = 0.0;
  print.width = 3.0;
  print.height = 1.5;
  printed.wall_prints = {print};
  const cv::Mat mural = renderer.render(printed, p).image;
  const cv::Point hole(cvRound(a.truth.hole->x), cvRound(a.truth.hole->y));
  ASSERT_TRUE(a.truth.bore_visible);
  EXPECT_EQ(mural.at<cv::Vec3b>(hole), a.image.at<cv::Vec3b>(hole));
  EXPECT_GT(cv::norm(mural, a.image, cv::NORM_L1) / (mural.total() * mural.channels()), 2.0);
}

TEST(WallPrint, HardScenesHaveMuralsOnHalfAndPrintsOnThreeInFour)
{
  int murals = 0;
  int printed = 0;
  std::array<int, 5> kinds{};
  for (std::uint64_t seed = 1; seed <= 400; ++seed)
  {
    const sv::SceneParams s = sv::randomHardScene(sv::SceneKind::kSpool, seed);
    const bool mural = !s.wall_prints.empty() && s.wall_prints.front().width > 2.0;
    murals += mural ? 1 : 0;
    printed += s.wall_prints.size() > (mural ? 1u : 0u) ? 1 : 0;
    for (const sv::WallPrint& print : s.wall_prints)
      ++kinds[static_cast<std::size_t>(print.kind)];
    // The main set keeps its plain walls.
    EXPECT_TRUE(sv::randomScene(sv::SceneKind::kSpool, seed).wall_prints.empty());
  }
  EXPECT_NEAR(murals / 400.0, 0.5, 0.07);
  EXPECT_NEAR(printed / 400.0, 0.75, 0.06);
  for (int n : kinds)
    EXPECT_GT(n, 60);
}

// A packed shelf (packShelf, the packed set): 1-3 neighbours each side, their rims touching on
// half the scenes; a back row on seven spool scenes in ten and on no negative's; the rest of the
// scene as it was drawn.
TEST(PackedShelf, NeighboursTouchOnHalfTheScenesAndABackRowStandsOnSevenInTen)
{
  int touching = 0;
  int back_rows = 0;
  for (std::uint64_t seed = 1; seed <= 400; ++seed)
  {
    const sv::SceneParams hard = sv::randomHardScene(sv::SceneKind::kSpool, seed);
    sv::SceneParams packed = hard;
    sv::packShelf(seed, packed);
    std::array<int, 2> per_side{};
    bool all_touch = true;
    for (const sv::NeighbourSpool& n : packed.neighbours)
    {
      ++per_side[n.side < 0 ? 0 : 1];
      all_touch &= n.gap == 0.0;
      EXPECT_LE(n.gap, 0.015);
    }
    for (int count : per_side)
    {
      EXPECT_GE(count, 1);
      EXPECT_LE(count, 3);
    }
    touching += all_touch ? 1 : 0;
    if (packed.back_row.z > 0.0)
    {
      ++back_rows;
      EXPECT_GE(packed.back_row.z, packed.bore_length);
      EXPECT_LE(packed.back_row.z, packed.bore_length + 0.06);
    }
    EXPECT_EQ(packed.wall_prints.size(), hard.wall_prints.size());
    EXPECT_EQ(packed.illuminance, hard.illuminance);
    EXPECT_EQ(packed.wall_gap, hard.wall_gap);
    sv::SceneParams plate = sv::randomHardScene(sv::SceneKind::kPlate, seed);
    sv::packShelf(seed, plate);
    EXPECT_EQ(plate.back_row.z, 0.0);
  }
  EXPECT_NEAR(touching / 400.0, 0.5, 0.07);
  EXPECT_NEAR(back_rows / 400.0, 0.7, 0.07);
}

TEST(PackedShelf, TheBackRowStandsBehindTheGapsAndIsInTheTruth)
{
  const sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(320, 240);
  const sv::SpoolRenderer renderer(k);
  const sv::SceneParams open = cleanScene();
  sv::SceneParams deep = open;
  deep.back_row.z = deep.bore_length + 0.03;
  deep.back_row.offset = 0.19;
  deep.back_row.gap = 0.02;
  const sv::CameraPose p = pose(0.8);
  const double depth = std::sqrt(0.64 - 0.06 * 0.06);

  // Spools every 37 cm from x = 0.19 within 1 m of the slot: -0.92 ... 0.93, behind the front row.
  const sv::GroundTruth gt = renderer.groundTruth(deep, p);
  std::vector<double> xs;
  for (const sv::NeighbourTruth& n : gt.neighbours)
  {
    ASSERT_TRUE(n.back_row);
    EXPECT_NEAR(n.distance, depth + deep.back_row.z, 1e-9);
    xs.push_back((n.flange.centre_x - k.cx) * n.distance / k.fx);
  }
  ASSERT_EQ(xs.size(), 6u);
  for (std::size_t i = 0; i < xs.size(); ++i)
    EXPECT_NEAR(xs[i], -0.92 + 0.37 * static_cast<double>(i), 1e-9);

  // Just beside the slot's rim, at the axis' height: the wall of the open shelf, the back row's
  // black face on the deep one.
  const double u = k.cx + k.fx * 0.2 / depth;
  const double v = k.cy + k.fy * 0.06 / depth;
  EXPECT_LT(bilinear(grey(renderer.render(deep, p).image), u, v),
            0.5 * bilinear(grey(renderer.render(open, p).image), u, v));

  // With the front row's rims touching, the back row is seen in the gaps beside the contact (here
  // 12 cm above it, 6 cm above the camera) and lies in the front row's shade: darker by half than
  // the slot's face of the same plastic, which the lamps and the room light.
  sv::SceneParams packed = deep;
  packed.neighbours = {{-1, 0.0, 0.0}, {1, 0.0, 0.0}};
  const cv::Mat packed_image = grey(renderer.render(packed, p).image);
  EXPECT_LT(bilinear(packed_image, k.cx + k.fx * 0.175 / depth, k.cy - k.fy * 0.06 / depth),
            0.5 * bilinear(packed_image, k.cx + k.fx * 0.1 / depth, v));

  sv::SceneParams overlapping = deep;
  overlapping.back_row.z = 0.5 * overlapping.bore_length;
  EXPECT_THROW(renderer.render(overlapping, p), std::invalid_argument);
}

TEST(PackedShelf, ABackRowFlangeBehindTheBoreLeavesNoLensInIt)
{
  // As BoreShowsThroughOnlyNearTheAxis: on the axis, 6 cm above it, the lens shows; a back-row
  // face 2 cm behind the bore's back end (its own hole 5 cm aside) leaves it dark.
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::SceneParams open = cleanScene();
  sv::SceneParams deep = open;
  deep.back_row.z = deep.bore_length + 0.02;
  deep.back_row.offset = 0.05;
  const sv::RenderedFrame lit = renderer.render(open, pose(0.55));
  const sv::RenderedFrame dark = renderer.render(deep, pose(0.55));
  ASSERT_TRUE(lit.truth.bore_visible);
  EXPECT_FALSE(dark.truth.bore_visible);
  EXPECT_EQ(dark.truth.hole_lit_fraction, 0.0);
  const sv::ProjectedCircle& hole = *lit.truth.hole;
  const double lens_at = hole.y - 0.8 * hole.r;
  EXPECT_LT(bilinear(grey(dark.image), hole.x, lens_at), 0.5 * bilinear(grey(lit.image), hole.x, lens_at));
}
