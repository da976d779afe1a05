// The spool axis from the bore's parallax on drawn frames: the front and back openings of a bore
// projected through a pinhole, the lit wall seen through where they overlap, every pixel by its
// exact coverage (16 x 16 subsamples). The answers are the drawing's own axis.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "spool_vision/bore_parallax.h"

namespace
{
using spool_vision::CameraIntrinsics;
using spool_vision::DiscOverlap;
using spool_vision::GeometryParams;

const CameraIntrinsics kCamera{800.0, 800.0, 320.0, 240.0, 640, 480, {}};
constexpr double kBoreRadius = 0.018;
constexpr double kDeg = M_PI / 180.0;

// Gamma 1: the drawing is in linear light already.
const std::array<float, 256> kIdentityLight = []
{
  std::array<float, 256> light{};
  for (std::size_t i = 0; i < light.size(); ++i)
    light[i] = static_cast<float>(i) / 255.0f;
  return light;
}();

// `gray` read as light.
spool_vision::LinearLight lightOf(const cv::Mat& gray)
{
  return {&gray, kIdentityLight.data()};
}

struct Opening
{
  cv::Point2d centre;
  double radius;
};

// The opening of radius kBoreRadius centred at `p` (camera frame, m), as a circle in the image.
Opening project(const cv::Point3d& p)
{
  return {{kCamera.cx + kCamera.fx * p.x / p.z, kCamera.cy + kCamera.fy * p.y / p.z}, kCamera.fy * kBoreRadius / p.z};
}

bool inside(const Opening& o, double x, double y)
{
  return (x - o.centre.x) * (x - o.centre.x) + (y - o.centre.y) * (y - o.centre.y) <= o.radius * o.radius;
}

// The face (120), the dark bore (20) and the lit wall (230) where both openings let it through;
// `spot` (px, radius) adds a lit blob inside the bore (a lamp's reflection on its wall).
cv::Mat drawBore(const Opening& front, const Opening& back, const Opening& spot = {{0.0, 0.0}, 0.0})
{
  cv::Mat gray(kCamera.height, kCamera.width, CV_8UC1, cv::Scalar(120));
  constexpr int kSub = 16;
  const int x0 = cvFloor(front.centre.x - front.radius) - 1;
  const int y0 = cvFloor(front.centre.y - front.radius) - 1;
  const int x1 = cvCeil(front.centre.x + front.radius) + 1;
  const int y1 = cvCeil(front.centre.y + front.radius) + 1;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x)
    {
      double sum = 0.0;
      for (int j = 0; j < kSub; ++j)
        for (int i = 0; i < kSub; ++i)
        {
          const double sx = x - 0.5 + (i + 0.5) / kSub;
          const double sy = y - 0.5 + (j + 0.5) / kSub;
          if (!inside(front, sx, sy))
            sum += 120.0;
          else if (inside(back, sx, sy) || inside(spot, sx, sy))
            sum += 230.0;
          else
            sum += 20.0;
        }
      gray.at<uchar>(y, x) = cv::saturate_cast<uchar>(sum / (kSub * kSub));
    }
  return gray;
}

// The bore's front centre 6 cm below the camera (the puller's place) at `depth`, `lateral` m to
// the right, its axis turned `yaw` and pitched `pitch` (rad); the back opening hub_length along it.
struct Bore
{
  cv::Point3d front;
  cv::Point3d back;
};
Bore boreAt(double depth, double lateral, double yaw, double pitch)
{
  const cv::Vec3d axis = cv::normalize(cv::Vec3d(std::tan(yaw), std::tan(pitch), 1.0));
  const cv::Point3d front(lateral, 0.06, depth);
  const double length = GeometryParams().hub_length;
  return {front, front + cv::Point3d(axis[0], axis[1], axis[2]) * length};
}

// What measureLens() and axisFromBoreParallax() make of the drawing of `bore`.
std::optional<spool_vision::ParallaxAxis> measureDrawn(const Bore& bore, const Opening& spot = {{0.0, 0.0}, 0.0})
{
  const Opening front = project(bore.front);
  const cv::Mat gray = drawBore(front, project(bore.back), spot);
  std::vector<float> samples;
  const std::optional<spool_vision::LensView> lens =
      spool_vision::measureLens(lightOf(gray), kCamera, front.centre, front.radius, samples);
  if (!lens)
    return std::nullopt;
  return spool_vision::axisFromBoreParallax(GeometryParams(), kCamera, front.centre, bore.front.z, *lens);
}
}  // namespace

TEST(DiscOverlap, MatchesPixelCountingInEveryCase)
{
  // Partial overlaps on either side of the chord's midpoint, one disc inside the other, apart.
  struct Case
  {
    cv::Point2d c2;
    double r2;
  };
  const cv::Point2d c1(0.0, 0.0);
  const double r1 = 20.0;
  for (const Case& k : {Case{{3.0, 25.0}, 14.0}, Case{{-4.0, 9.0}, 15.0}, Case{{1.0, -2.0}, 8.0},
                        Case{{0.0, 0.0}, 30.0}, Case{{40.0, 0.0}, 10.0}})
  {
    double area = 0.0;
    cv::Point2d moment(0.0, 0.0);
    constexpr double kStep = 0.05;
    constexpr int kCells = 800;  // 40 px across
    for (int j = 0; j < kCells; ++j)
      for (int i = 0; i < kCells; ++i)
      {
        const cv::Point2d p(-20.0 + (i + 0.5) * kStep, -20.0 + (j + 0.5) * kStep);
        if (p.dot(p) <= r1 * r1 && (p - k.c2).dot(p - k.c2) <= k.r2 * k.r2)
        {
          area += kStep * kStep;
          moment += p * (kStep * kStep);
        }
      }
    const DiscOverlap o = spool_vision::discOverlap(c1, r1, k.c2, k.r2);
    EXPECT_NEAR(o.area, area, 0.002 * 1256.6 + 1e-9) << k.c2;
    if (area > 0.0)
    {
      EXPECT_NEAR(o.centroid.x, moment.x / area, 0.01) << k.c2;
      EXPECT_NEAR(o.centroid.y, moment.y / area, 0.01) << k.c2;
    }
    else
    {
      EXPECT_TRUE(std::isnan(o.centroid.x));
    }
  }
}

TEST(BoreParallax, GivesTheDrawnYaw)
{
  // Near the insertion window the back opening shifts 3.8 px per degree of yaw here.
  for (const double yaw_deg : {-1.0, -0.3, 0.0, 0.5, 1.2})
  {
    const auto axis = measureDrawn(boreAt(0.55, 0.0, yaw_deg * kDeg, 0.0));
    ASSERT_TRUE(axis) << yaw_deg;
    EXPECT_NEAR(std::atan(axis->slopes[0]) / kDeg, yaw_deg, 0.02) << yaw_deg;
    EXPECT_NEAR(std::atan(axis->slopes[1]) / kDeg, 0.0, 0.1) << yaw_deg;
  }
  // Off to the side, the lens moves with the bearing as well: still the axis's own yaw.
  const auto beside = measureDrawn(boreAt(0.6, 0.004, 0.7 * kDeg, 0.0));
  ASSERT_TRUE(beside);
  EXPECT_NEAR(std::atan(beside->slopes[0]) / kDeg, 0.7, 0.02);
}

TEST(BoreParallax, YawIsSharpPitchIsNotWithTheCameraAboveTheBore)
{
  // The vertical parallax is mostly the 6 cm camera height over the bore's length, which spools
  // do not share exactly: the pitch's sigma is several times the yaw's.
  const auto axis = measureDrawn(boreAt(0.55, 0.0, 0.0, 0.0));
  ASSERT_TRUE(axis);
  const double yaw_sigma = std::sqrt(axis->covariance(0, 0));
  const double pitch_sigma = std::sqrt(axis->covariance(1, 1));
  EXPECT_GT(yaw_sigma, 0.0);
  EXPECT_LT(yaw_sigma, 0.1 * kDeg);
  EXPECT_GT(pitch_sigma, 3.0 * yaw_sigma);
}

TEST(BoreParallax, NothingFromADarkBoreOrALensTheModelCannotMake)
{
  // No lit lens (the openings do not overlap: far off the axis).
  EXPECT_FALSE(measureDrawn(boreAt(0.55, 0.12, 0.0, 0.0)));
  // A lamp's reflection in the dark part of the bore, half the lens's size: the lit area is
  // not the two openings' overlap.
  const Bore bore = boreAt(0.55, 0.0, 0.0, 0.0);
  const Opening front = project(bore.front);
  const Opening spot{front.centre + cv::Point2d(0.0, 0.6 * front.radius), 0.3 * front.radius};
  EXPECT_FALSE(measureDrawn(bore, spot));
}

TEST(BoreParallax, MeasureLensRejectsAFrameItCannotRead)
{
  std::vector<float> samples;
  const cv::Mat gray = drawBore(project(boreAt(0.55, 0.0, 0.0, 0.0).front), project(boreAt(0.55, 0.0, 0.0, 0.0).back));
  // A disc too small, one leaving the frame, a colour frame.
  EXPECT_FALSE(spool_vision::measureLens(lightOf(gray), kCamera, {320.0, 240.0}, 4.0, samples));
  EXPECT_FALSE(spool_vision::measureLens(lightOf(gray), kCamera, {3.0, 240.0}, 20.0, samples));
  cv::Mat colour;
  cv::merge(std::vector<cv::Mat>{gray, gray, gray}, colour);
  EXPECT_FALSE(spool_vision::measureLens(lightOf(colour), kCamera, {320.0, 240.0}, 20.0, samples));
}
