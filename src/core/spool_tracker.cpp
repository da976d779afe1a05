#include "spool_vision/spool_tracker.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "spool_vision/camera_model.h"
#include "spool_vision/spool_geometry.h"

namespace spool_vision
{
namespace
{
// The measured error model (docs/error_model.md, scripts/measure_error_model.py: seeds 21-22 of
// the main, hard, distorted and approach sets). 1 sigma of a detection on the target spool with a
// hole rim, by image height. The errors are roughly constant in px across sizes, heavy-tailed and
// correlated from frame to frame (lag-1 0.7-0.9 along an approach), so the radius and centre rows
// are the p95-implied sigmas (p95 / 1.96), not the MAD ones, and the axis is the hard set's sigma
// times 1.5.
struct ErrorRow
{
  double height;             // image rows
  double radius_px;          // flange rim radius
  double centre_px;          // the bore's front centre
  double axis;               // rad, per slope of the spool axis
  double no_hole_centre_px;  // the flange's centre standing in for the bore's (3 x its MAD sigma)
};
constexpr std::array<ErrorRow, 4> kErrorModel = {{
    {120.0, 0.18, 0.35, 0.0445, 0.6},
    {240.0, 0.17, 0.15, 0.0113, 1.2},
    {480.0, 0.25, 0.23, 0.0079, 2.4},
    {720.0, 0.26, 0.28, 0.0055, 3.3},
}};
// A flange with under 90% of its rim in view: the same core, worse tails (radius and axis up to
// 1.7x the whole flange's at some sizes; the centre, measured on the bore's rim, no worse).
constexpr double kCutFlangeFactor = 1.5;
constexpr double kCutFraction = 0.9;
// The axis comes from the rim's shape, whose offset per degree of tilt falls as 1 / depth^2
// (f (R/Z)^2 sin(tilt), DESIGN.md §5): the model's axis sigma holds at this depth (m, the middle
// of the measured 50-110 cm) and scales with (depth / it)^2.
constexpr double kAxisModelDepth = 0.8;

// A concentric rib ring's size, as a fraction of the flange's: 0.64-0.65 in heldout_v2's
// seq2_36-37, up to 0.86 (the outermost rib) on the renderer's ribbed faces.
constexpr double kRibRingMin = 0.5;
constexpr double kRibRingMax = 0.9;

// Velocity sigma of a new track (m/s): a forklift approaches at up to ~0.3 m/s.
constexpr double kInitialSpeedSigma = 0.5;

// Variance (rad^2) of an axis slope a measurement does not observe: a 1 rad sigma leaves it to
// the other measurements.
constexpr double kUnobservedSlopeVariance = 1.0;

ErrorRow interpolatedRow(int image_height)
{
  const double h = static_cast<double>(image_height);
  if (h <= kErrorModel.front().height)
    return kErrorModel.front();
  for (std::size_t i = 1; i < kErrorModel.size(); ++i)
  {
    const ErrorRow& a = kErrorModel[i - 1];
    const ErrorRow& b = kErrorModel[i];
    if (h <= b.height)
    {
      const double t = (h - a.height) / (b.height - a.height);
      auto mix = [t](double u, double v) { return u + t * (v - u); };
      return {h, mix(a.radius_px, b.radius_px), mix(a.centre_px, b.centre_px), mix(a.axis, b.axis),
              mix(a.no_hole_centre_px, b.no_hole_centre_px)};
    }
  }
  return kErrorModel.back();
}

Eigen::Vector3d toEigen(const cv::Point3d& p)
{
  return {p.x, p.y, p.z};
}

// Covariance (m^2) of a position `p` measured from the image: its depth error `relative_z` (of z)
// runs along the ray through it (p = z (u, v, 1): a scale error moves the whole ray), the centre's
// pixel error `centre_px` across it.
Eigen::Matrix3d rayCovariance(const Eigen::Vector3d& p, double relative_z, double centre_px,
                              const CameraIntrinsics& camera)
{
  const double z = p.z();
  const Eigen::Vector3d ray = p / z;
  const double sigma_z = z * relative_z;
  const double sigma_across = z * centre_px / std::max(std::min(camera.fx, camera.fy), 1.0);
  Eigen::Matrix3d r = sigma_z * sigma_z * ray * ray.transpose();
  r(0, 0) += sigma_across * sigma_across;
  r(1, 1) += sigma_across * sigma_across;
  return r;
}

// The flange radius a detection's depth comes from (px): Eq. 3.2's.
double flangeRadiusPx(const SpoolDetection& d)
{
  return std::max(d.flange.r_vertical > 0.0 ? d.flange.r_vertical : d.flange.r, 1.0);
}

// px from the `reference` pixel (the detector's, in frame px) to where the point `p` (m, camera
// optical frame) shows in the frame: the distance the detector's target rule orders spools by.
double referenceDistance(const cv::Point3d& p, const cv::Point2d& reference, const CameraIntrinsics& camera)
{
  const cv::Point2d seen = distortPixel(camera, {camera.cx + camera.fx * p.x / p.z, camera.cy + camera.fy * p.y / p.z});
  return std::hypot(seen.x - reference.x, seen.y - reference.y);
}

// Covariance (m^2) of a detection's position (rayCovariance: Eq. 3.2's depth from the flange radius).
Eigen::Matrix3d positionCovariance(const SpoolDetection& d, const MeasurementNoise& noise,
                                   const CameraIntrinsics& camera)
{
  return rayCovariance(toEigen(d.position), noise.radius_px / flangeRadiusPx(d), noise.centre_px, camera);
}

// The part of a detection's position covariance no filter averages out. Its errors are
// correlated from frame to frame (lag-1 0.7-0.9 along an approach: docs/error_model.md) and
// biased per sequence (shelf, lamps): over approach seeds 41-50 each sequence's mean flange
// radius error was -0.04 to -0.38 px, RMS 0.24-0.26 px at every size from 160x120 to 1280x720 (the
// rim comes out ~0.2 px small); the centre error drifts over seconds (at 160x120 2-4 mm off for a
// whole approach). So the track never claims its position better than one detection measures it:
// that detection's covariance, with a radius sigma of at least this RMS (px), is a bias of the
// whole track. (A bias of the per-sequence means alone, 0.25 px radius and 0.15 px centre, held the
// truth in 3 sigma on 92% of the frames at 160x120; this floor 97%.)
constexpr double kRadiusBiasPx = 0.25;

Eigen::Matrix3d correlatedCovariance(const SpoolDetection& d, const MeasurementNoise& noise,
                                     const CameraIntrinsics& camera, const TrackerParams& params)
{
  MeasurementNoise bias = noise;
  bias.radius_px = std::max(noise.radius_px, params.noise_scale * kRadiusBiasPx);
  return positionCovariance(d, bias, camera);
}

bool usable(const SpoolDetection& d)
{
  return d.detected && std::isfinite(d.position.x) && std::isfinite(d.position.y) && std::isfinite(d.position.z) &&
         d.position.z > 0.0;
}

bool hasAxis(const SpoolDetection& d)
{
  return d.hole_detected && std::isfinite(d.axis[0]) && std::isfinite(d.axis[1]) && std::isfinite(d.axis[2]) &&
         d.axis[2] > 0.0;
}

// Largest standard deviation of a 2-D vector with covariance `c`.
double largestSigma(const Eigen::Matrix2d& c)
{
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(c);
  return std::sqrt(std::max(solver.eigenvalues().maxCoeff(), 0.0));
}
}  // namespace

const char* toString(AxisCue cue)
{
  switch (cue)
  {
    case AxisCue::kNone:
      return "none";
    case AxisCue::kRim:
      return "rim";
    case AxisCue::kBoreParallax:
      return "bore_parallax";
  }
  return "unknown";
}

const char* toString(TrackState state)
{
  switch (state)
  {
    case TrackState::kSearching:
      return "searching";
    case TrackState::kTracking:
      return "tracking";
    case TrackState::kCoasting:
      return "coasting";
    case TrackState::kLost:
      return "lost";
  }
  return "unknown";
}

MeasurementNoise measurementNoise(const SpoolDetection& d, int image_height, const TrackerParams& params)
{
  const ErrorRow row = interpolatedRow(image_height);
  const bool cut = d.flange.visible_fraction < kCutFraction;
  MeasurementNoise noise;
  noise.radius_px = params.noise_scale * row.radius_px * (cut ? kCutFlangeFactor : 1.0);
  noise.centre_px = params.noise_scale * (d.hole_detected ? row.centre_px : row.no_hole_centre_px);
  const double depth_factor = std::isfinite(d.position.z) ? std::pow(d.position.z / kAxisModelDepth, 2.0) : 1.0;
  noise.axis = d.hole_detected ? params.noise_scale * row.axis * (cut ? kCutFlangeFactor : 1.0) * depth_factor
                               : std::numeric_limits<double>::infinity();
  return noise;
}

SpoolTracker::SpoolTracker(const DetectorParams& params) : params_(params) {}

void SpoolTracker::setParams(const DetectorParams& params)
{
  params_ = params;
}

bool SpoolTracker::young() const
{
  return fused_frames_ < params_.tracker.confirm_frames;
}

void SpoolTracker::reset()
{
  active_ = false;
  axis_known_ = false;
  rib_ratio_.reset();
  last_stamp_.reset();
  last_interval_ = 0.0;
  coasted_ = confirmed_ = consecutive_.count = whole_frame_.count = 0;
  tracked_ = TrackedSpool();
}

const TrackedSpool& SpoolTracker::update(const SpoolDetection& detection, double stamp, const CameraIntrinsics& camera,
                                         bool whole_frame, const std::optional<CameraMotion>& motion)
{
  const bool time_jumped = last_stamp_ && (stamp < *last_stamp_ || stamp - *last_stamp_ > kMaxGap);
  const double dt = last_stamp_ && !time_jumped ? stamp - *last_stamp_ : 0.0;
  last_stamp_ = stamp;
  last_interval_ = dt;
  if (time_jumped || tracked_.state == TrackState::kLost)
  {
    // A bag played again, a paused stream, or a track that ended: search afresh.
    active_ = false;
    axis_known_ = false;
  }
  tracked_.rejected_now = false;
  tracked_.fused_now = false;
  const MeasurementNoise noise = measurementNoise(detection, camera.height, params_.tracker);
  // Its own key: at 320x240 the filter's sigma could decide, but a biased depth is not in it.
  fine_enough_ = 1.0 / camera.fy <= params_.tracker.aligned_max_pixel_angle;

  if (!active_)
  {
    if (usable(detection) && detection.hole_detected)
    {
      start(detection, noise, camera);
      publish(true);
    }
    else
    {
      tracked_ = TrackedSpool();
    }
    return tracked_;
  }

  predict(dt, motion);
  bool fused = false;
  bool followed_rib = false;
  if (usable(detection) && isRibRing(detection))
  {
    followed_rib = followRibRing(detection, noise, camera);
    checkpoint_.valid = false;  // a ring fused at a learnt scale is not replayed
  }
  else if (usable(detection))
  {
    // One that agrees with the detection refused on the frame before is that other thing again (a
    // circle too big, taken on frame after frame), however close the gate, widened by the
    // coasting, lets it come: refused, it counts towards ending the track (refuteTrack), the way
    // for the flange a track drifted from to come back, through a new track.
    // Unless the refused ones agree with the track without its last fused detection, better than
    // that one did: it was the outlier (a blurred rim measured 3% large), which turned the velocity
    // the prediction runs on, and the spool's own rim has been refused since.
    const Eigen::Vector3d position = toEigen(detection.position);
    const Eigen::Matrix3d covariance = positionCovariance(detection, noise, camera);
    fused = (!repeatsRefused(detection, covariance) && fuseMeasurement(position, covariance)) ||
            fusedWithoutTheLastFused(dt, motion, position, covariance);
    if (fused)
    {
      rib_ratio_.reset();  // the next rib episode learns its ring's size afresh
      ++fused_frames_;
      bias_ = correlatedCovariance(detection, noise, camera, params_.tracker);
      fuseAxis(detection, noise);
      support_ = detection.confidence;
      consecutive_.count = 0;
      if (whole_frame)
        whole_frame_.count = 0;
    }
    else if (refuteTrack(detection, noise, camera, whole_frame))
    {
      tracked_.state = TrackState::kLost;
      tracked_.aligned = false;
      confirmed_ = 0;
      return tracked_;
    }
  }
  else if (checkpoint_.valid)
  {
    checkpoint_.steps.push_back({dt, motion, false, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero()});
  }
  // A frame that followed the rib ring neither counts as coasted nor clears the count.
  coasted_ = fused ? 0 : coasted_ + (followed_rib ? 0 : 1);
  // A track younger than track_confirm_frames fused frames has no velocity to coast on (the robot's
  // 1-3 cm a frame at 10 Hz is 1-3% of the depth per frame): it ends at the first frame it misses.
  if (coasted_ > (young() ? 0 : params_.tracker.max_coast))
  {
    tracked_.state = TrackState::kLost;
    tracked_.aligned = false;
    confirmed_ = 0;
    return tracked_;
  }
  publish(fused);
  return tracked_;
}

void SpoolTracker::start(const SpoolDetection& detection, const MeasurementNoise& noise, const CameraIntrinsics& camera)
{
  active_ = true;
  x_.setZero();
  x_.head<3>() = toEigen(detection.position);
  p_.setZero();
  p_.topLeftCorner<3, 3>() = positionCovariance(detection, noise, camera);
  p_.bottomRightCorner<3, 3>() = kInitialSpeedSigma * kInitialSpeedSigma * Eigen::Matrix3d::Identity();
  bias_ = correlatedCovariance(detection, noise, camera, params_.tracker);
  rib_ratio_.reset();
  axis_known_ = false;
  fuseAxis(detection, noise);
  support_ = detection.confidence;
  coasted_ = confirmed_ = consecutive_.count = whole_frame_.count = 0;
  checkpoint_.valid = false;
  fused_frames_ = 1;
  tracked_ = TrackedSpool();
  tracked_.age = 0;
}

void SpoolTracker::predict(double dt, const std::optional<CameraMotion>& motion)
{
  if (motion)
    turnAxisWithCamera(*motion);
  predictPosition(x_, p_, dt, motion);
  if (axis_known_)
  {
    axis_p_ += params_.tracker.axis_drift * params_.tracker.axis_drift * dt * Eigen::Matrix2d::Identity();
    applyLevelPitch();
  }
}

void SpoolTracker::predictPosition(Vector6& x, Matrix6& p, double dt, const std::optional<CameraMotion>& motion) const
{
  if (motion)
    moveWithCamera(x, p, *motion);
  Matrix6 f = Matrix6::Identity();
  f.topRightCorner<3, 3>() = dt * Eigen::Matrix3d::Identity();
  // White-noise acceleration, per axis [[dt^4/4, dt^3/2], [dt^3/2, dt^2]] q.
  const double q = params_.tracker.acceleration * params_.tracker.acceleration;
  Matrix6 noise = Matrix6::Zero();
  noise.topLeftCorner<3, 3>() = q * dt * dt * dt * dt / 4.0 * Eigen::Matrix3d::Identity();
  noise.topRightCorner<3, 3>() = q * dt * dt * dt / 2.0 * Eigen::Matrix3d::Identity();
  noise.bottomLeftCorner<3, 3>() = noise.topRightCorner<3, 3>();
  noise.bottomRightCorner<3, 3>() = q * dt * dt * Eigen::Matrix3d::Identity();
  x = f * x;
  p = f * p * f.transpose() + noise;
}

namespace
{
Eigen::Matrix3d toEigen(const cv::Matx33d& m)
{
  Eigen::Matrix3d e;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      e(r, c) = m(r, c);
  return e;
}

// rad, the angle `rotation` turns by (its axis-angle's)
double turnAngle(const Eigen::Matrix3d& rotation)
{
  return std::acos(std::clamp(0.5 * (rotation.trace() - 1.0), -1.0, 1.0));
}
}  // namespace

void SpoolTracker::moveWithCamera(Vector6& x, Matrix6& p, const CameraMotion& motion) const
{
  const Eigen::Matrix3d r = toEigen(motion.rotation);
  const Eigen::Vector3d t(motion.translation[0], motion.translation[1], motion.translation[2]);
  const Eigen::Vector3d before = x.head<3>();
  Matrix6 rr = Matrix6::Zero();
  rr.topLeftCorner<3, 3>() = r;
  rr.bottomRightCorner<3, 3>() = r;
  x = rr * x;
  x.head<3>() += t;
  p = rr * p * rr.transpose();
  // The odometry's own error: a fraction of the distance driven, and of the angle turned, which
  // swings the point by that angle times its distance from the camera.
  const double k = params_.tracker.odometry_noise;
  const double angle = turnAngle(r);
  const double position_var = std::pow(k * t.norm(), 2.0) + std::pow(k * angle * before.norm(), 2.0);
  p.topLeftCorner<3, 3>() += position_var * Eigen::Matrix3d::Identity();
}

void SpoolTracker::turnAxisWithCamera(const CameraMotion& motion)
{
  if (!axis_known_)
    return;
  // The axis direction (sx, sy, 1) turns with the camera; its slopes are the new direction's
  // x/z and y/z, whose Jacobian in the old slopes carries their covariance across.
  const Eigen::Matrix3d r = toEigen(motion.rotation);
  const Eigen::Vector3d d = r * Eigen::Vector3d(axis_.x(), axis_.y(), 1.0);
  if (!(d.z() > 1e-6))
    return;  // turned a quarter turn between two frames: no forklift does that
  Eigen::Matrix<double, 2, 3> ds;
  ds << 1.0 / d.z(), 0.0, -d.x() / (d.z() * d.z()), 0.0, 1.0 / d.z(), -d.y() / (d.z() * d.z());
  const Eigen::Matrix2d j = ds * r.leftCols<2>();
  axis_ = Eigen::Vector2d(d.x() / d.z(), d.y() / d.z());
  const double k = params_.tracker.odometry_noise;
  axis_p_ = j * axis_p_ * j.transpose() + std::pow(k * turnAngle(r), 2.0) * Eigen::Matrix2d::Identity();
}

void SpoolTracker::applyLevelPitch()
{
  const double sigma = params_.tracker.level_pitch_sigma;
  if (!(sigma > 0.0))
    return;
  // A fact about the scene, not a measurement: it neither drifts nor averages down.
  axis_.y() = params_.tracker.level_pitch;
  axis_p_(1, 1) = sigma * sigma;
  axis_p_(0, 1) = axis_p_(1, 0) = 0.0;
}

bool SpoolTracker::fusePosition(Vector6& x, Matrix6& p, const Eigen::Vector3d& position,
                                const Eigen::Matrix3d& covariance, double& distance2) const
{
  const Eigen::Vector3d innovation = position - x.head<3>();
  const Eigen::Matrix3d s = p.topLeftCorner<3, 3>() + covariance;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(s);
  distance2 = innovation.dot(ldlt.solve(innovation));
  if (!(distance2 <= params_.tracker.gate * params_.tracker.gate))
    return false;
  // K = P H^T S^-1 with H = [I 0]; Joseph form keeps P symmetric and positive.
  const Eigen::Matrix<double, 6, 3> k = ldlt.solve(p.topRows<3>()).transpose();
  x += k * innovation;
  Eigen::Matrix<double, 3, 6> h = Eigen::Matrix<double, 3, 6>::Zero();
  h.leftCols<3>().setIdentity();
  const Matrix6 i_kh = Matrix6::Identity() - k * h;
  p = i_kh * p * i_kh.transpose() + k * covariance * k.transpose();
  return true;
}

bool SpoolTracker::fuseMeasurement(const Eigen::Vector3d& position, const Eigen::Matrix3d& covariance)
{
  const Vector6 x = x_;
  const Matrix6 p = p_;
  double distance2 = 0.0;
  if (!fusePosition(x_, p_, position, covariance, distance2))
    return false;
  checkpoint_.valid = true;
  checkpoint_.x = x;
  checkpoint_.p = p;
  checkpoint_.distance2 = distance2;
  checkpoint_.steps.clear();
  return true;
}

bool SpoolTracker::fusedWithoutTheLastFused(double dt, const std::optional<CameraMotion>& motion,
                                            const Eigen::Vector3d& position, const Eigen::Matrix3d& covariance)
{
  if (!checkpoint_.valid)
    return false;
  checkpoint_.steps.push_back({dt, motion, true, position, covariance});
  int measured = 0;
  for (const ReplayStep& step : checkpoint_.steps)
    measured += step.measured ? 1 : 0;
  if (measured < kReplayedDetections)
    return false;
  // From the track before the last fused detection, every frame since: each detection must pass
  // the gate and agree with that history better than the skipped one did.
  Vector6 x = checkpoint_.x;
  Matrix6 p = checkpoint_.p;
  Vector6 x_last = x;
  Matrix6 p_last = p;
  double distance2_last = 0.0;
  for (const ReplayStep& step : checkpoint_.steps)
  {
    predictPosition(x, p, step.dt, step.motion);
    if (!step.measured)
      continue;
    x_last = x;
    p_last = p;
    if (!fusePosition(x, p, step.position, step.covariance, distance2_last) || distance2_last >= checkpoint_.distance2)
      return false;
  }
  x_ = x;
  p_ = p;
  // The last of them is now the last fused detection.
  checkpoint_.x = x_last;
  checkpoint_.p = p_last;
  checkpoint_.distance2 = distance2_last;
  checkpoint_.steps.clear();
  return true;
}

bool SpoolTracker::isRibRing(const SpoolDetection& detection) const
{
  // Its bore centre inside the track's bore opening (another spool's lies a flange or more away)
  // and its flange kRibRingMin to kRibRingMax of the one the track predicts (depth / its depth):
  // this spool's rib ring taken for the flange (its bore centre found a little off: 0.018 rad in
  // heldout_v2's seq2_36). However well it fits the gate (a track that coasted a few frames
  // admits 15%), it is never the flange. (Any other ratio may be the flange itself against a
  // track that started on something else.)
  // Not against a young track: its first frame may have been the wrong circle (one too big, about
  // the bore, makes the flange itself look like a ring inside it), or its prediction may have run
  // away (a wrong second frame gives it a metre a second).
  if (young())
    return false;
  const Eigen::Vector3d p = x_.head<3>();
  const Eigen::Vector3d q = toEigen(detection.position);
  const Eigen::Vector2d bearing(q.x() / q.z() - p.x() / p.z(), q.y() / q.z() - p.y() / p.z());
  const double ring = p.z() / q.z();
  return ring >= kRibRingMin && ring <= kRibRingMax && bearing.norm() <= 0.5 * params_.geometry.hole_diameter / p.z();
}

bool SpoolTracker::followRibRing(const SpoolDetection& detection, const MeasurementNoise& noise,
                                 const CameraIntrinsics& camera)
{
  ++tracked_.rejected;
  tracked_.rejected_now = true;
  // The ring's size is a fixed fraction of the flange's: learnt from the track at its first
  // sighting, it turns the ring's depth into the bore's, so the track follows the spool (the
  // robot may stop at the insertion window) instead of coasting on its last velocity.
  const Eigen::Vector3d p = x_.head<3>();
  const Eigen::Vector3d q = toEigen(detection.position);
  const double ring_var = std::pow(noise.radius_px / flangeRadiusPx(detection), 2.0);  // relative, of the ring's depth
  if (!rib_ratio_)
  {
    rib_ratio_ = p.z() / q.z();
    rib_ratio_var_ = *rib_ratio_ * *rib_ratio_ * (p_(2, 2) / (p.z() * p.z()) + ring_var);
    return true;
  }
  // Along the ray through its bore centre, at the ratio's depth; the ratio's error is shared by
  // every frame of the episode: a bias of the track.
  const Eigen::Vector3d position = *rib_ratio_ * q;
  const Eigen::Matrix3d covariance = rayCovariance(
      position, std::sqrt(ring_var + rib_ratio_var_ / (*rib_ratio_ * *rib_ratio_)), noise.centre_px, camera);
  if (!fuseMeasurement(position, covariance))
    return false;  // another rib of the face (60-86% of the flange): the ratio is not its
  bias_ = covariance;
  return true;
}

void SpoolTracker::fuseAxis(const SpoolDetection& detection, const MeasurementNoise& noise)
{
  const bool rim = hasAxis(detection) && std::isfinite(noise.axis);
  const bool parallax = detection.parallax_measured;
  if (!rim && !parallax)
    return;
  const double scale2 = params_.tracker.noise_scale * params_.tracker.noise_scale;
  // The parallax's yaw alone: its pitch came out 0.2-0.3 deg biased on rendered approaches
  // (docs/tracking_evaluation.md), worse than the rim's, so that slope is left to the rim.
  Eigen::Matrix2d parallax_r = Eigen::Matrix2d::Zero();
  parallax_r(0, 0) = scale2 * detection.parallax_covariance(0, 0);
  parallax_r(1, 1) = kUnobservedSlopeVariance;
  const Eigen::Vector2d parallax_slopes(detection.parallax_slopes[0], detection.parallax_slopes[1]);
  const Eigen::Vector2d rim_slopes =
      rim ? Eigen::Vector2d(detection.axis[0] / detection.axis[2], detection.axis[1] / detection.axis[2])
          : Eigen::Vector2d::Zero();
  Eigen::Matrix2d rim_r = noise.axis * noise.axis * Eigen::Matrix2d::Identity();
  if (params_.tracker.level_pitch_sigma > 0.0)
    rim_r(1, 1) = kUnobservedSlopeVariance;  // the level pitch stands in for the rim's
  if (!axis_known_)
  {
    // Started from the rim where it gave an axis, the parallax then fused into it.
    axis_known_ = true;
    axis_refused_ = 0;
    axis_ = rim ? rim_slopes : parallax_slopes;
    axis_p_ = rim ? rim_r : parallax_r;
    const bool parallax_fused = rim && parallax && fuseSlopes(parallax_slopes, parallax_r);
    axis_cue_ = rim && !parallax_fused ? AxisCue::kRim : AxisCue::kBoreParallax;
    applyLevelPitch();
    return;
  }
  // The parallax first: the rim's measurement is then gated against the sharper axis.
  const bool parallax_fused = parallax && fuseSlopes(parallax_slopes, parallax_r);
  if (parallax_fused)
    axis_cue_ = AxisCue::kBoreParallax;
  if (!rim)
  {
    applyLevelPitch();
    return;
  }
  if (fuseSlopes(rim_slopes, rim_r))
  {
    if (!parallax_fused)
      axis_cue_ = AxisCue::kRim;
    axis_refused_ = 0;
    applyLevelPitch();
    return;
  }
  // An axis far off the track's (a fit that followed a label) is not fused; the position was.
  // Refused twice in a row, the track's axis is the stale one (the robot turned faster than
  // track_axis_drift allows): it starts again from this measurement.
  if (!parallax_fused && ++axis_refused_ >= 2)
  {
    axis_ = rim_slopes;
    axis_p_ = rim_r;
    axis_refused_ = 0;
    confirmed_ = 0;
    axis_cue_ = AxisCue::kRim;
  }
  applyLevelPitch();
}

bool SpoolTracker::fuseSlopes(const Eigen::Vector2d& slopes, const Eigen::Matrix2d& covariance)
{
  const Eigen::Vector2d innovation = slopes - axis_;
  const Eigen::Matrix2d s = axis_p_ + covariance;
  if (!(innovation.dot(s.ldlt().solve(innovation)) <= params_.tracker.gate * params_.tracker.gate))
    return false;
  const Eigen::Matrix2d k = axis_p_ * s.inverse();
  axis_ += k * innovation;
  axis_p_ = (Eigen::Matrix2d::Identity() - k) * axis_p_;
  axis_p_ = 0.5 * (axis_p_ + axis_p_.transpose());
  return true;
}

double SpoolTracker::distance2To(const Refuter& refuter, const Eigen::Vector3d& offset,
                                 const Eigen::Matrix3d& covariance) const
{
  // Two refused detections of one other thing agree with each other within both their errors
  // and the track's own uncertainty.
  if (refuter.count == 0)
    return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d d = offset - refuter.offset;
  const Eigen::Matrix3d s = covariance + refuter.cov + p_.topLeftCorner<3, 3>();
  return d.dot(s.ldlt().solve(d));
}

bool SpoolTracker::repeatsRefused(const SpoolDetection& detection, const Eigen::Matrix3d& covariance) const
{
  if (consecutive_.count < 1)
    return false;
  const Eigen::Vector3d offset = toEigen(detection.position) - x_.head<3>();
  const double to_refused = distance2To(consecutive_, offset, covariance);
  // Nearer the refused thing than the track, too: a coasting track's uncertainty makes the spool's
  // own detection agree with both (a circle 6% too big refused twice, then the flange again).
  const Eigen::Matrix3d to_track = covariance + p_.topLeftCorner<3, 3>();
  return to_refused <= params_.tracker.gate * params_.tracker.gate &&
         to_refused < offset.dot(to_track.ldlt().solve(offset));
}

bool SpoolTracker::refuteTrack(const SpoolDetection& detection, const MeasurementNoise& noise,
                               const CameraIntrinsics& camera, bool whole_frame)
{
  ++tracked_.rejected;
  tracked_.rejected_now = true;
  const Eigen::Vector3d p = x_.head<3>();
  const Eigen::Vector3d q = toEigen(detection.position);
  // Relative to the track: the camera's motion moves both alike (the spools stand still).
  const Eigen::Vector3d offset = q - p;
  const Eigen::Matrix3d cov = positionCovariance(detection, noise, camera);
  auto count = [&](Refuter& refuter)
  {
    refuter.count =
        distance2To(refuter, offset, cov) <= params_.tracker.gate * params_.tracker.gate ? refuter.count + 1 : 1;
    refuter.offset = offset;
    refuter.cov = cov;
    return refuter.count >= 2;
  };
  // In a row, or on whole-frame searches in a row (a windowed search between them keeps finding
  // the track's spool, which a neighbour taken at first sight would stay forever).
  const bool consistent = count(consecutive_);
  const bool consistent_whole = whole_frame && count(whole_frame_);
  // The stronger evidence: a hole rim at least as well supported as the track's last fused one.
  // A track with fewer than track_confirm_frames fused frames has no history to hold against any
  // other refusal (two frames, one of them wrong, give it a velocity of a metre a second, and
  // coasting on it runs away from the spool): it ends at once.
  // Or the whole frame's target by the detector's own rule (DESIGN.md §5): a hole rim nearer the
  // puller's reference than the track's spool by more than a flange radius, another spool's
  // place. Its confidence is not held against the track's, which windowed searches fill (a window
  // whose prior stands in for part of the rim scores 1 where the whole frame's search scores 0.8).
  const bool the_target =
      consistent_whole && detection.hole_detected &&
      referenceDistance(detection.position, detection.reference, camera) + flangeRadiusPx(detection) <
          referenceDistance({p.x(), p.y(), p.z()}, detection.reference, camera);
  return ((consistent || consistent_whole) && detection.hole_detected && detection.confidence >= support_) ||
         the_target || young();
}

void SpoolTracker::publish(bool fused)
{
  // A track younger than track_confirm_frames fused frames is held but not yet published: its first
  // spool may be a neighbour the detector's target rule took at first sight (the puller's reference
  // between two spools at the start of an approach), which a whole-frame search in the next frames
  // corrects. It could not be aligned before then anyway (aligned needs as many frames).
  tracked_.state = young() ? TrackState::kSearching : fused ? TrackState::kTracking : TrackState::kCoasting;
  tracked_.fused_now = fused;
  ++tracked_.age;
  tracked_.position = {x_(0), x_(1), x_(2)};
  tracked_.velocity = {x_(3), x_(4), x_(5)};
  const Eigen::Matrix3d covariance = publishedCovariance();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      tracked_.position_covariance(r, c) = covariance(r, c);
  if (axis_known_)
  {
    const Eigen::Vector3d n = Eigen::Vector3d(axis_.x(), axis_.y(), 1.0).normalized();
    tracked_.axis = {n.x(), n.y(), n.z()};
    tracked_.axis_sigma = largestSigma(axis_p_);
    tracked_.axis_cue = axis_cue_;
  }
  else
  {
    tracked_.axis = {TrackedSpool::kNaN, TrackedSpool::kNaN, TrackedSpool::kNaN};
    tracked_.axis_sigma = TrackedSpool::kNaN;
  }
  decideAligned();
}

Eigen::Matrix3d SpoolTracker::publishedCovariance() const
{
  return p_.topLeftCorner<3, 3>() + bias_;
}

void SpoolTracker::decideAligned()
{
  const GeometryParams& g = params_.geometry;
  tracked_.front_miss = tracked_.back_miss = tracked_.miss_sigma = TrackedSpool::kNaN;
  bool clears = false;
  if (axis_known_)
  {
    pullerMiss(g, tracked_.position, tracked_.axis, tracked_.front_miss, tracked_.back_miss);
    // The miss vectors are linear in the position's x, y and the axis's slopes: at the front the
    // position's covariance, at the back that plus bore_length_max^2 times the slopes'. The
    // largest direction's sigma bounds the miss's (its own direction is unknown near zero).
    const Eigen::Matrix2d front_cov = publishedCovariance().topLeftCorner<2, 2>();
    const Eigen::Matrix2d back_cov = front_cov + g.bore_length_max * g.bore_length_max * axis_p_;
    const double front_sigma = largestSigma(front_cov);
    const double back_sigma = largestSigma(back_cov);
    tracked_.miss_sigma = std::max(front_sigma, back_sigma);
    const double clearance = (g.hole_diameter - g.puller_diameter) / 2.0 - g.aligned_margin;
    const double k = params_.tracker.aligned_sigma;
    clears = tracked_.fused_now && tracked_.front_miss + k * front_sigma <= clearance &&
             tracked_.back_miss + k * back_sigma <= clearance;
  }
  // The clearance is confirmed over the frames before the insertion window too, so that aligned
  // can come on the first frame inside it.
  confirmed_ = clears ? confirmed_ + 1 : 0;
  const double depth = tracked_.position.z;
  tracked_.aligned = fine_enough_ && confirmed_ >= params_.tracker.confirm_frames && depth >= g.aligned_distance_min &&
                     depth <= g.aligned_distance_max;
}

std::optional<FlangeWindow> SpoolTracker::flangeWindow(double stamp, const CameraIntrinsics& camera,
                                                       const std::optional<CameraMotion>& motion) const
{
  // Only a track with a velocity, in the next frame: a young track's first spool may be a
  // neighbour taken while the target was not found; after a gap of dropped frames the window and
  // the gate are wide enough to admit the wrong circle the window's lowered sensitivity finds (one
  // fused there turns the velocity, and the track runs off). A coasting track keeps its window: a
  // rib ring followed at the end of an approach leaves the flange, cut by the frame, to it.
  if (!active_ || tracked_.state == TrackState::kLost || young() || !last_stamp_)
    return std::nullopt;
  const double dt = stamp - *last_stamp_;
  if (dt < 0.0 || dt > kMaxGap || (last_interval_ > 0.0 && dt > kDroppedFrameRatio * last_interval_))
    return std::nullopt;
  Eigen::Vector3d p = x_.head<3>() + dt * x_.tail<3>();
  // The prediction's covariance (the position block of F P F^T + Q) is close enough to P's
  // position block grown by the velocity's over dt; the margins are generous multiples anyway.
  Eigen::Matrix3d cov = p_.topLeftCorner<3, 3>() + dt * dt * p_.bottomRightCorner<3, 3>();
  if (motion)
  {
    const Eigen::Matrix3d r = toEigen(motion->rotation);
    p = r * p + Eigen::Vector3d(motion->translation[0], motion->translation[1], motion->translation[2]);
    cov = r * cov * r.transpose();
  }
  std::optional<FlangeWindow> window = flangeWindowAt(p, cov, camera, params_);
  // The whole rim for moving edges: the flange's circle about the predicted bore, in the plane the
  // tracked axis gives (facing the camera before a hole rim gave one). Only after a fused frame:
  // moving edges see what they are shown, and a rim they measured wrong (a neighbour's arc or the
  // back flange's silhouette along part of it) would be measured wrong again on every frame
  // while the gate refuses it; after a refusal or a miss the window's Hough search judges the
  // whole window.
  if (!window || params_.tracker.measurement != TrackMeasurement::kMovingEdges ||
      tracked_.state != TrackState::kTracking)
    return window;
  Eigen::Vector3d axis(0.0, 0.0, 1.0);
  double axis_sigma = params_.matcher.max_view_angle;
  if (axis_known_)
  {
    axis = Eigen::Vector3d(axis_.x(), axis_.y(), 1.0).normalized();
    axis_sigma = largestSigma(axis_p_);
    if (motion)
      axis = toEigen(motion->rotation) * axis;
  }
  const double f = std::max(camera.fx, camera.fy);
  const double z = p.z();
  const double rim = params_.geometry.flange_diameter / 2.0;
  window->rim = RimPrediction{{p.x(), p.y(), z}, {axis.x(), axis.y(), axis.z()}, rim};
  // 3 sigma of where the rim can be: the centre across, the radius with the depth, and the rim
  // tilting with the axis (its near and far sides at depths R sin(tilt) apart); never as far as
  // a rib ring (at most 86% of the flange's size).
  const double sigma_across = std::sqrt(std::max(cov(0, 0), cov(1, 1))) / z;
  const double sigma_depth = std::sqrt(cov(2, 2)) / z;
  const double reach =
      3.0 * (f * sigma_across + window->radius * sigma_depth + window->radius * (rim / z) * axis_sigma) + kRimReachPad;
  window->rim_reach = std::min(reach, std::max(kMaxRimReach * window->radius, kRimReachPad));
  window->bore_reach = 3.0 * f * sigma_across + 1.0;
  return window;
}

std::optional<FlangeWindow> flangeWindowAt(const Eigen::Vector3d& p, const Eigen::Matrix3d& cov,
                                           const CameraIntrinsics& camera, const DetectorParams& params)
{
  const double z = p.z();
  if (!(z > 0.05))
    return std::nullopt;
  const double f = std::max(camera.fx, camera.fy);
  const double sigma_across = std::sqrt(std::max(cov(0, 0), cov(1, 1))) / z;  // rad
  const double sigma_depth = std::sqrt(cov(2, 2)) / z;                        // relative
  const double rim = params.geometry.flange_diameter / 2.0;
  FlangeWindow window;
  window.centre = {camera.fx * p.x() / z + camera.cx, camera.fy * p.y() / z + camera.cy};
  window.radius = camera.fy * rim / z;
  window.centre_margin =
      3.0 * f * sigma_across + f * (rim / z) * (rim / z) * std::sin(params.matcher.max_view_angle) + 2.0;
  window.radius_margin = window.radius * (3.0 * sigma_depth + SpoolTracker::kRadiusSpread);
  return window;
}

TrackingDetector::TrackingDetector(const DetectorParams& params) : detector_(params), tracker_(params) {}

void TrackingDetector::setParams(const DetectorParams& params)
{
  detector_.setParams(params);
  tracker_.setParams(params);
}

TrackedFrame TrackingDetector::process(const cv::Mat& image, PixelFormat format, double stamp,
                                       const std::optional<CameraMotion>& motion, const std::optional<TargetHint>& hint)
{
  TrackedFrame frame;
  std::optional<FlangeWindow> whole;  // what "the whole frame" is: all of it, or the hint's window
  auto offHint = [&](const cv::Point3d& p)
  { return std::hypot(p.x - hint->position.x, p.y - hint->position.y, p.z - hint->position.z) > hint->radius; };
  if (hint)
  {
    const TrackedSpool& held = tracker_.current();
    if ((held.state == TrackState::kTracking || held.state == TrackState::kCoasting) && offHint(held.position))
      tracker_.reset();  // following another spool than the task's
    const double sigma = hint->radius / 3.0;
    whole = flangeWindowAt({hint->position.x, hint->position.y, hint->position.z},
                           Eigen::Matrix3d::Identity() * sigma * sigma, detector_.cameraFor(image.size()),
                           detector_.params());
    if (whole)
      whole->whole_frame = true;
  }
  // Not the task's spool: a neighbour in a wide window (a young track's), or a rim at another depth.
  auto taskless = [&](const SpoolDetection& d) { return hint && d.detected && offHint(d.position); };
  const int interval = detector_.params().tracker.full_search_interval;
  std::optional<FlangeWindow> window;
  if (since_full_search_ + 1 < interval)
    window = tracker_.flangeWindow(stamp, detector_.camera(), motion);
  if (window)
  {
    frame.raw = detector_.detect(image, format, window);
    // Nothing where the spool should be: it moved more than the model allows, or the window
    // was wrong. The whole frame decides, in this frame.
    frame.full_search = !frame.raw.detected || taskless(frame.raw);
  }
  if (!window || frame.full_search)
  {
    const double windowed_ms = window ? frame.raw.time_ms : 0.0;
    // A hint behind the camera leaves nothing that can be the target.
    frame.raw = hint && !whole ? SpoolDetection() : detector_.detect(image, format, whole);
    if (taskless(frame.raw))
    {
      const double ms = frame.raw.time_ms;
      frame.raw = SpoolDetection();
      frame.raw.time_ms = ms;
    }
    frame.raw.time_ms += windowed_ms;
  }
  since_full_search_ = frame.full_search ? 0 : since_full_search_ + 1;
  frame.track = tracker_.update(frame.raw, stamp, detector_.camera(), frame.full_search, motion);
  // The whole frame refused: the next frame's whole frame decides whether that was another spool
  // (two in a row end the track: SpoolTracker::refuteTrack), not the one track_full_search_interval
  // frames on. A track taken on a neighbour at first sight (the target's face missed far off)
  // held it for two intervals: approach_hard seed 84 at 640x480 and 1280x720, 20 frames.
  if (frame.full_search && frame.track.rejected_now)
    since_full_search_ = interval - 1;
  frame.published = trackedDetection(frame.raw, frame.track, detector_.params().geometry);
  return frame;
}

SpoolDetection trackedDetection(const SpoolDetection& raw, const TrackedSpool& track, const GeometryParams& geometry)
{
  SpoolDetection out = raw;
  const bool held = track.state == TrackState::kTracking || track.state == TrackState::kCoasting;
  out.detected = held;
  out.aligned = held && track.aligned;
  if (!held || !track.fused_now)
  {
    // Not this frame's spool: its rims and per-frame tests say nothing about the track.
    out.hole_detected = false;
    out.overlapped = false;
    out.lens_detected = false;
    out.flange = Circle();
    out.hole = Circle();
    out.lens = Circle();
    out.confidence = 0.0;
  }
  if (!held)
  {
    const double nan = SpoolDetection::kNaN;
    out.distance = out.range = out.yaw = out.lateral_offset = out.axis_angle = out.axis_yaw = nan;
    out.position = {nan, nan, nan};
    out.axis = {nan, nan, nan};
    return out;
  }
  out.position = track.position;
  out.distance = track.position.z;
  out.range = std::sqrt(track.position.dot(track.position));
  out.lateral_offset = track.position.x - geometry.puller_offset_x;
  out.yaw = std::atan2(out.lateral_offset, track.position.z);
  out.axis = track.axis;
  out.axis_angle =
      std::isfinite(track.axis[2]) ? std::acos(std::clamp(track.axis[2], -1.0, 1.0)) : SpoolDetection::kNaN;
  out.axis_yaw = std::isfinite(track.axis[2]) ? std::atan2(track.axis[0], track.axis[2]) : SpoolDetection::kNaN;
  return out;
}

}  // namespace spool_vision
