// libFuzzer target: SpoolDetector::detect on arbitrary frames. The first bytes choose the frame's
// size (tiny, odd and below the minimum included), pixel format (and a matrix type that does not
// match it), memory layout (contiguous or a view into a larger matrix), parameter set and camera
// (none, pinhole, plumb_bob or rational_polynomial distortion, another size, invalid); the rest
// fills the pixels. detect() must return or throw std::invalid_argument (its documented error);
// anything else escaping, a crash or a sanitizer report is a bug. Each frame is processed twice
// by the same detector: the second call takes the steady-state path with every buffer sized. A
// third call measures it as a track would (moving edges along a predicted rim: the first call's
// spool, or one 1 m ahead), with the same checks.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <optional>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "spool_vision/spool_detector.h"

namespace sv = spool_vision;

namespace
{
// The largest frame: the thesis' 160x120 (every stage's code path, a few hundred frames a
// second under the sanitizers; 640x480 is the gtests').
constexpr int kMaxWidth = 160;
constexpr int kMaxHeight = 120;
constexpr std::size_t kHeaderBytes = 16;

// Reads the header bytes in order; zeros once the input is shorter than the header.
class Header
{
public:
  Header(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t byte()
  {
    return next_ < size_ && next_ < kHeaderBytes ? data_[next_++] : 0;
  }
  std::uint16_t word()
  {
    const std::uint16_t low = byte();
    return static_cast<std::uint16_t>(low | byte() << 8);
  }
  /// A value in [-limit, limit] from one byte.
  double signedUnit(double limit)
  {
    return (byte() - 127.5) / 127.5 * limit;
  }

private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t next_ = 0;
};

// Parameter sets that reach the other pre-processing and matching branches.
sv::DetectorParams paramsVariant(std::uint8_t choice)
{
  sv::DetectorParams p;
  switch (choice % 6)
  {
    case 1:  // the thesis pipeline (config/seed.yaml): binarized, opened, area-opened, cht
      p.preprocess.binarize = sv::BinarizeType::kFixed;
      p.preprocess.morphology = sv::MorphologyType::kOpen;
      p.preprocess.min_component_area = 30;
      p.hough.flange_polarity = sv::Polarity::kDark;
      p.hough.hole_polarity = sv::Polarity::kBright;
      p.matcher.mode = sv::MatchMode::kCht;
      break;
    case 2:
      p.preprocess.filter = sv::FilterType::kMedian;
      p.preprocess.binarize = sv::BinarizeType::kOtsu;
      p.preprocess.morphology = sv::MorphologyType::kDilate;
      p.matcher.spool_evidence = sv::SpoolEvidence::kFlange;
      break;
    case 3:
      p.preprocess.filter = sv::FilterType::kUnsharp;
      p.hough.flange_polarity = sv::Polarity::kAny;
      p.matcher.spool_evidence = sv::SpoolEvidence::kHole;
      break;
    case 4:
      p.preprocess.filter = sv::FilterType::kAverage;
      p.preprocess.filter_kernel = 5;
      p.geometry.yaw_mode = sv::YawMode::kLinearFov;
      p.geometry.reference_mode = sv::ReferenceMode::kFixed;
      break;
    case 5:
      p.preprocess.filter = sv::FilterType::kNone;
      p.hough.edge_threshold = 0.001;  // the lowest allowed: every pixel of noise is an edge
      p.hough.hole_edge_threshold = 0.001;
      break;
    default:  // config/default.yaml
      break;
  }
  return p;
}

// The camera kinds; intrinsics from header bytes within what a calibration can give.
sv::CameraIntrinsics cameraVariant(Header& h, std::uint8_t kind, int width, int height)
{
  sv::CameraIntrinsics k = sv::CameraIntrinsics::thesisDefault(width, height);
  k.fx *= 1.0 + h.signedUnit(0.5);
  k.fy = k.fx * (1.0 + h.signedUnit(0.05));
  k.cx += h.signedUnit(0.2) * width;
  k.cy += h.signedUnit(0.2) * height;
  switch (kind)
  {
    case 2:  // plumb_bob: k1, k2, p1, p2, k3
      k.distortion = {h.signedUnit(0.5), h.signedUnit(0.5), h.signedUnit(0.02), h.signedUnit(0.02), h.signedUnit(0.5)};
      break;
    case 3:  // rational_polynomial
      k.distortion = {h.signedUnit(0.5), h.signedUnit(0.5), h.signedUnit(0.02), h.signedUnit(0.02),
                      h.signedUnit(0.5), h.signedUnit(0.5), h.signedUnit(0.5),  h.signedUnit(0.5)};
      break;
    case 4:  // calibrated for another image size: the detector falls back to the thesis camera
      k.width += 1 + h.byte();
      break;
    default:
      break;
  }
  return k;
}

// The window a track holding `d`'s spool would give the next frame (a spool 1 m ahead without one).
sv::FlangeWindow trackedWindow(const sv::SpoolDetection& d, const sv::CameraIntrinsics& camera,
                               const sv::DetectorParams& params)
{
  const bool held = d.detected && d.position.z > 0.05;
  const cv::Point3d p = held ? d.position : cv::Point3d(0.0, 0.0, 1.0);
  const double rim = params.geometry.flange_diameter / 2.0;
  sv::FlangeWindow w;
  w.centre = {camera.fx * p.x / p.z + camera.cx, camera.fy * p.y / p.z + camera.cy};
  w.radius = camera.fy * rim / p.z;
  w.centre_margin = 6.0;
  w.radius_margin = 0.1 * w.radius;
  w.rim = {p, held ? d.axis : cv::Vec3d(0.0, 0.0, 1.0), rim};
  w.rim_reach = 8.0;
  w.bore_reach = 3.0;
  return w;
}

void check(bool ok, const char* what)
{
  if (!ok)
  {
    std::cerr << "detector_fuzz: " << what << "\n";
    std::abort();
  }
}
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
  // OpenCV's worker threads make runs slower on a shared machine and their timing nondeterministic.
  cv::setNumThreads(0);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  Header h(data, size);
  const int width = h.word() % (kMaxWidth + 1);
  const int height = h.word() % (kMaxHeight + 1);
  const std::uint8_t format_byte = h.byte();
  const auto format = static_cast<sv::PixelFormat>(format_byte % 6);
  // Now and then a matrix type that does not fit the format (documented: invalid_argument).
  const bool mistyped = format_byte >= 0xe0;
  const int type = !mistyped ? sv::matTypeOf(format) : sv::matTypeOf(format) == CV_8UC3 ? CV_16UC1 : CV_8UC3;
  const std::uint8_t camera_kind = h.byte() % 6;
  const sv::DetectorParams params = paramsVariant(h.byte());
  const std::uint8_t layout = h.byte();
  const sv::CameraIntrinsics camera = cameraVariant(h, camera_kind, width, height);

  // The pixels: the bytes after the header, repeated to fill the frame (zeros without any).
  const bool view = layout & 1;
  cv::Mat storage(height + (view ? 3 : 0), width + (view ? 5 : 0), type, cv::Scalar::all(0));
  cv::Mat image = view ? storage(cv::Rect(2, 1, width, height)) : storage;
  if (size > kHeaderBytes && !image.empty())
  {
    const std::uint8_t* pixels = data + kHeaderBytes;
    const std::size_t count = size - kHeaderBytes;
    const std::size_t row_bytes = image.cols * image.elemSize();
    std::size_t at = 0;
    for (int y = 0; y < image.rows; ++y)
    {
      std::uint8_t* row = image.ptr<std::uint8_t>(y);
      for (std::size_t x = 0; x < row_bytes; ++x, at = at + 1 == count ? 0 : at + 1)
        row[x] = pixels[at];
    }
  }

  sv::SpoolDetector detector(params);
  if (camera_kind != 0)
  {
    sv::CameraIntrinsics given = camera;
    if (camera_kind == 5)
      given.fx = 0.0;
    // Documented: an invalid camera (no focal length, no size: a 0-pixel frame's) is refused.
    try
    {
      detector.setCamera(given);
      check(given.valid(), "setCamera() took an invalid camera");
    }
    catch (const std::invalid_argument&)
    {
      check(!given.valid(), "setCamera() refused a valid camera");
    }
  }

  // Documented: an empty, too small or mistyped frame is refused with std::invalid_argument.
  const bool refused = image.empty() || width < sv::SpoolDetector::kMinImageSide ||
                       height < sv::SpoolDetector::kMinImageSide || mistyped;
  std::optional<sv::FlangeWindow> window;
  for (int pass = 0; pass < 3; ++pass)
  {
    try
    {
      const sv::SpoolDetection d = detector.detect(image, format, window);
      if (pass == 1)
        window = trackedWindow(d, detector.camera(), params);
      check(!refused, "detect() took a frame it must refuse");
      check(!d.detected || (d.flange.r > 0.0 && d.confidence > 0.0 && d.confidence <= 1.0),
            "a detection without a flange radius or with confidence outside (0, 1]");
      check(!d.hole_detected || d.detected, "a hole without a flange");
      // No number outside physics: the depth agrees with Eq. 3.2 on the flange's size, an axis
      // lies within 40 deg of the line of sight (SpoolGeometry::measure's check).
      const double eq32 = detector.camera().fy * params.geometry.flange_diameter / (2.0 * d.flange.r_vertical);
      check(!d.detected || (std::isfinite(d.distance) && std::abs(d.distance / eq32 - 1.0) <= 0.15 + 1e-9),
            "a depth more than 15% off Eq. 3.2's");
      const cv::Vec3d ray = cv::normalize(cv::Vec3d(d.position.x, d.position.y, d.position.z));
      check(!std::isfinite(d.axis[2]) ||
                std::acos(std::min(1.0, std::abs(ray.dot(d.axis)))) <= 40.0 * M_PI / 180.0 + 1e-9,
            "an axis more than 40 deg off the line of sight");
    }
    catch (const std::invalid_argument&)
    {
      check(refused, "detect() refused a valid frame");
    }
  }
  return 0;
}
