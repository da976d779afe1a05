// Stage 5: one spool followed over the approach, from first confident sight to insertion
// (DESIGN.md §8). The camera moves and the spool does not, so the bore's front centre moves in
// the camera optical frame as smoothly as the robot drives: a Kalman filter with a
// constant-velocity model fuses each frame's detection, weighted by a measured error model, and
// refuses a detection that disagrees with the prediction (a rib ring taken for the flange) instead
// of passing a 30 cm jump to the controller. `aligned` is decided on the filtered state and its
// uncertainty, confirmed over consecutive frames.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
#include "spool_vision/spool_detector.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// The track's state in a frame. The values are the SpoolPose message's TRACK_* constants
/// (TRACK_OFF = 0 is a node without tracking).
enum class TrackState : std::uint8_t
{
  kSearching = 1,  ///< no track: waiting for a detection with a hole rim
  kTracking = 2,   ///< this frame's detection was fused
  kCoasting = 3,   ///< no detection, or one refused by the gate: the prediction, flagged
  kLost = 4        ///< the track ended in this frame (coasted too long, or a consistent other spool)
};

/// "searching", "tracking", "coasting", "lost".
const char* toString(TrackState state);

/// Where the latest measurement fused into the tracked axis came from (kept while coasting). The values are the
/// SpoolPose message's AXIS_CUE_* constants.
enum class AxisCue : std::uint8_t
{
  kNone = 0,          ///< no axis: no hole rim yet, or no track
  kRim = 1,           ///< the flange rim's ellipse alone (SpoolGeometry::fitRimPose)
  kBoreParallax = 2,  ///< the bore's parallax (bore_parallax.h), with the rim's where it agreed
};

/// "none", "rim", "bore_parallax".
const char* toString(AxisCue cue);

/// 1-sigma measurement noise of one detection (the error model, docs/error_model.md).
struct MeasurementNoise
{
  double radius_px = 0.0;  ///< flange rim radius, px: depth sigma = depth * radius_px / r_px
  double centre_px = 0.0;  ///< the bore's front centre in the image, px
  double axis = 0.0;       ///< rad, each of the spool axis's two slopes; infinite without a hole rim
};

/// The measured error model of the detector (docs/error_model.md: the table it comes from),
/// scaled by track_noise_scale: the flange radius, the bore centre and the axis, by the image
/// height the camera streams (interpolated in between), the radius and axis times 1.5 for a
/// flange cut by the frame border (under 90% of its rim in view); without a hole rim the flange's
/// centre stands in for the bore's (up to f (R/Z)^2 sin(tilt) px off) and the axis is unknown.
MeasurementNoise measurementNoise(const SpoolDetection& detection, int image_height, const TrackerParams& params);

/// The camera's motion between two frames, as the robot's odometry gives it: a point fixed in the
/// scene at p (m) in the earlier frame's camera optical frame (REP 103) is at rotation * p +
/// translation in the later one's. The identity is a camera that stood still.
struct CameraMotion
{
  cv::Matx33d rotation = cv::Matx33d::eye();
  cv::Vec3d translation{0.0, 0.0, 0.0};  ///< m
};

/// What the tracker holds after a frame. Positions in the camera optical frame (REP 103), m.
struct TrackedSpool
{
  static constexpr double kNaN = SpoolDetection::kNaN;

  TrackState state = TrackState::kSearching;
  int age = 0;       ///< frames since the track started (0 without a track)
  int rejected = 0;  ///< detections refused by the gate since the track started
  /// This frame's detection disagreed with the prediction by more than track_gate (Mahalanobis)
  bool rejected_now = false;
  bool fused_now = false;                  ///< this frame's detection was fused
  cv::Point3d position{kNaN, kNaN, kNaN};  ///< the bore's front centre, filtered (m)
  cv::Vec3d velocity{kNaN, kNaN, kNaN};    ///< its velocity relative to the camera (m/s)
  /// m^2, row-major: the filter's, plus one detection's own (its errors are correlated from frame
  /// to frame and biased per approach: no filtering removes them)
  cv::Matx33d position_covariance = cv::Matx33d::zeros();
  cv::Vec3d axis{kNaN, kNaN, kNaN};  ///< unit spool axis into the spool; NaN until a hole rim gave one
  double axis_sigma = kNaN;          ///< rad, 1 sigma of the axis's direction (the larger slope's)
  AxisCue axis_cue = AxisCue::kNone;
  /// The puller's miss of the bore's axis at its front and at bore_length_max along it (m), and
  /// the 1-sigma of the larger of the two (first-order propagation of the state covariance)
  double front_miss = kNaN;
  double back_miss = kNaN;
  double miss_sigma = kNaN;
  /// The filtered state clears the bore: each miss plus track_aligned_sigma sigmas within
  /// t_f - aligned_margin on track_confirm_frames fused frames in a row (this one among them),
  /// the depth in the insertion window, and a pixel no wider than track_aligned_max_pixel_angle
  bool aligned = false;
};

/// Follows one spool over an approach. Feed it every frame's detection in order with the frame's
/// stamp; it never switches silently to another spool: a new track starts only through `lost`.
class SpoolTracker
{
public:
  explicit SpoolTracker(const DetectorParams& params = DetectorParams());

  /// Replaces the parameters (already validated, as SpoolDetector's); the track goes on.
  void setParams(const DetectorParams& params);

  /// One frame: `detection` as SpoolDetector::detect() gave it for a frame stamped `stamp` (s,
  /// any epoch) from a camera of `camera` (the detector's: its focal length and image height
  /// pick the error model). A stamp before the last one (a bag played again) or more than
  /// kMaxGap after it restarts the search. `whole_frame`: the detection came from a search of the
  /// whole frame, not of flangeWindow(): two such detections in a row (whatever windowed frames
  /// lie between) refused by the gate, agreeing with each other and as strong, end the track.
  /// `motion`: the camera's motion since the previous frame, from odometry. It moves the track's
  /// position and turns its axis with the camera (the axis held in the camera frame otherwise
  /// lags the robot's turns by track_axis_drift); the constant-velocity model then keeps only
  /// what odometry does not see (the lift, its scale error). Without it the whole apparent motion
  /// is the constant-velocity model's. Give it on every frame or on none: a frame without it
  /// after frames with it predicts no travel for that frame.
  const TrackedSpool& update(const SpoolDetection& detection, double stamp, const CameraIntrinsics& camera,
                             bool whole_frame = true, const std::optional<CameraMotion>& motion = std::nullopt);

  const TrackedSpool& current() const
  {
    return tracked_;
  }

  /// Where the followed spool's flange will be in the frame stamped `stamp` (s): the prediction
  /// projected through `camera`'s pinhole (undistorted pixels). Centre margin: 3 sigma of the
  /// projected position plus the offset of a turned rim's ellipse centre from the projected
  /// centre, f (R/Z)^2 sin(max_view_angle); radius margin: 3 sigma of the depth plus
  /// kRadiusSpread (a rib ring is 60-86% of the flange's size, a neighbour's rim elsewhere).
  /// nullopt without a track (searching, lost), for a track younger than track_confirm_frames
  /// fused frames, after a gap over kDroppedFrameRatio times the interval before it (dropped
  /// frames), or when the prediction is not ahead of the camera: the whole frame is searched then. `motion`: the
  /// camera's since the last frame, as update() takes it.
  std::optional<FlangeWindow> flangeWindow(double stamp, const CameraIntrinsics& camera,
                                           const std::optional<CameraMotion>& motion = std::nullopt) const;

  /// Fraction of the predicted radius the flange window's radius margin adds.
  static constexpr double kRadiusSpread = 0.04;
  /// px the moving edges search beyond 3 sigma of the predicted rim (FlangeWindow::rim_reach).
  static constexpr double kRimReachPad = 2.0;
  /// The moving edges search at most this fraction of the predicted radius each way: a rib ring is
  /// at most 86% of the flange's size.
  static constexpr double kMaxRimReach = 0.07;

  /// Drops the track (e.g. a new camera).
  void reset();

  /// Seconds between frames beyond which the prediction is worthless (a paused stream).
  static constexpr double kMaxGap = 1.0;
  /// An interval this many times the one before means frames were dropped in between.
  static constexpr double kDroppedFrameRatio = 1.5;

private:
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  using Matrix6 = Eigen::Matrix<double, 6, 6>;

  /// Refused detections that agree with each other: how many, the last one's offset from the
  /// track (m) and its covariance
  struct Refuter
  {
    int count = 0;
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  };

  /// A frame since the last fused detection: its interval (s), the camera's motion, and the
  /// detection the gate refused in it, if any (camera frame, m; covariance m^2).
  struct ReplayStep
  {
    double dt = 0.0;
    std::optional<CameraMotion> motion;
    bool measured = false;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  };
  /// The position filter just before the last fused detection was fused, its squared Mahalanobis
  /// distance there, and the frames since (fusedWithoutTheLastFused()).
  struct Checkpoint
  {
    bool valid = false;
    Vector6 x = Vector6::Zero();
    Matrix6 p = Matrix6::Zero();
    double distance2 = 0.0;
    std::vector<ReplayStep> steps;
  };
  /// Refused detections that must agree with the track without its last fused one to replace it.
  static constexpr int kReplayedDetections = 2;

  /// Fewer than track_confirm_frames fused frames: no history to defend nor a velocity to coast
  /// on; searched in the whole frame, never following a rib ring.
  bool young() const;
  void start(const SpoolDetection& detection, const MeasurementNoise& noise, const CameraIntrinsics& camera);
  void predict(double dt, const std::optional<CameraMotion>& motion);
  /// The position filter's step to a frame `dt` s later (constant velocity, white-noise
  /// acceleration track_acceleration), after the camera's `motion`.
  void predictPosition(Vector6& x, Matrix6& p, double dt, const std::optional<CameraMotion>& motion) const;
  /// Position and velocity seen from the camera after `motion`: rotated and the position moved,
  /// plus the odometry's error (track_odometry_noise of the distance driven and of the angle turned).
  void moveWithCamera(Vector6& x, Matrix6& p, const CameraMotion& motion) const;
  /// The axis's slopes turned with the camera (first order for their covariance), plus the
  /// odometry's error of the angle turned.
  void turnAxisWithCamera(const CameraMotion& motion);
  /// One position measurement (camera frame, m) with covariance (m^2) into the state (x, p), gated
  /// at track_gate; `distance2`: its squared Mahalanobis distance from the prediction. True when fused.
  bool fusePosition(Vector6& x, Matrix6& p, const Eigen::Vector3d& position, const Eigen::Matrix3d& covariance,
                    double& distance2) const;
  /// fusePosition() into the track; the state before it is kept as checkpoint_.
  bool fuseMeasurement(const Eigen::Vector3d& position, const Eigen::Matrix3d& covariance);
  /// A detection the gate refused (position, covariance), in a frame `dt` s after the one before,
  /// with the camera's `motion`. With at least kReplayedDetections of them since the last fused
  /// detection, the frames since are taken again from checkpoint_ without that detection: when
  /// each refused one passes the gate there, and lies nearer than the skipped one lay (squared
  /// Mahalanobis distance), the skipped one was the outlier and the replayed state is the track's.
  /// True when it replaced the track's state.
  bool fusedWithoutTheLastFused(double dt, const std::optional<CameraMotion>& motion, const Eigen::Vector3d& position,
                                const Eigen::Matrix3d& covariance);
  /// The detection is this spool's own rib ring taken for the flange: its bore inside the track's
  /// bore opening and its flange kRibRingMin to kRibRingMax of the predicted one; never against a
  /// track with fewer than track_confirm_frames fused frames that has coasted since its last.
  bool isRibRing(const SpoolDetection& detection) const;
  /// Counts a rib ring as refused and follows it: its first sighting in an episode learns the
  /// ring's size relative to the flange (rib_ratio_), later ones are fused at that scale (the
  /// bore's bearing and the ring's depth). True when it learnt the ratio or fused the ring, false
  /// when the gate refused it (another rib of the face).
  bool followRibRing(const SpoolDetection& detection, const MeasurementNoise& noise, const CameraIntrinsics& camera);
  /// The rim's axis, then the bore's parallax where it was measured (its covariance times
  /// track_noise_scale^2). Each is gated against the track's axis; a rim refused twice in a row
  /// (the robot turned faster than track_axis_drift allows) restarts the axis, unless the
  /// parallax, which the rim's bias does not share, holds it.
  void fuseAxis(const SpoolDetection& detection, const MeasurementNoise& noise);
  /// With track_level_pitch_sigma > 0: the axis's pitch is the level one, with that variance.
  void applyLevelPitch();
  /// One axis measurement: true when fused, false when the gate refused it.
  bool fuseSlopes(const Eigen::Vector2d& slopes, const Eigen::Matrix2d& covariance);
  /// Counts a refused detection; true when it and the one before agree with each other and are
  /// the stronger evidence (another spool, or the track was wrong): the track is lost.
  bool refuteTrack(const SpoolDetection& detection, const MeasurementNoise& noise, const CameraIntrinsics& camera,
                   bool whole_frame);
  /// Squared Mahalanobis distance of the detection at `offset` from the track (m), with
  /// `covariance` (m^2), from the last one `refuter` counted, given both their errors and the
  /// track's (infinite when it counted none): within track_gate^2 it is the same thing.
  double distance2To(const Refuter& refuter, const Eigen::Vector3d& offset, const Eigen::Matrix3d& covariance) const;
  /// The detection (position covariance `covariance`) is the thing refused on the frame before
  /// (consecutive_) and lies nearer it than the track's prediction (Mahalanobis).
  bool repeatsRefused(const SpoolDetection& detection, const Eigen::Matrix3d& covariance) const;
  void publish(bool fused);
  /// The filter's position covariance plus the depth bias it cannot average out (bias_).
  Eigen::Matrix3d publishedCovariance() const;
  void decideAligned();

  DetectorParams params_;
  TrackedSpool tracked_;
  std::optional<double> last_stamp_;
  double last_interval_ = 0.0;  ///< s between the last two frames (0: none, or a restart)
  bool active_ = false;
  Vector6 x_ = Vector6::Zero();  ///< position (m), velocity (m/s)
  Matrix6 p_ = Matrix6::Zero();
  /// The last fused detection's covariance (its radius sigma at least the measured per-sequence
  /// bias) taken as a bias of the track (m^2, camera frame): published on top of p_ and used for
  /// aligned, never in the gate (which compares detections sharing that bias)
  Eigen::Matrix3d bias_ = Eigen::Matrix3d::Zero();
  Eigen::Vector2d axis_ = Eigen::Vector2d::Zero();  ///< the axis's slopes (x/z, y/z)
  Eigen::Matrix2d axis_p_ = Eigen::Matrix2d::Zero();
  bool axis_known_ = false;
  AxisCue axis_cue_ = AxisCue::kNone;  ///< of the latest measurement fused into axis_
  int axis_refused_ = 0;               ///< axis measurements refused in a row
  bool fine_enough_ = true;            ///< the camera's pixel subtends at most track_aligned_max_pixel_angle
  int coasted_ = 0;                    ///< frames in a row without a fused detection (a followed rib ring is neither)
  /// The depth of the bore over that of the rib ring taken for the flange (the ring's size relative
  /// to the flange's) and its variance: learnt at a rib episode's first frame, cleared by a fused flange
  std::optional<double> rib_ratio_;
  double rib_ratio_var_ = 0.0;
  int confirmed_ = 0;     ///< frames in a row whose filtered state cleared the bore
  int fused_frames_ = 0;  ///< detections fused since the track started (its first among them)
  double support_ = 0.0;  ///< confidence of the last fused detection
  Refuter consecutive_;   ///< in consecutive frames
  Refuter whole_frame_;   ///< in consecutive whole-frame searches
  Checkpoint checkpoint_;
};

/// One frame through the detector and the tracker, as the node and spool_detect --track run it.
struct TrackedFrame
{
  SpoolDetection raw;        ///< the detector's own result for the frame
  TrackedSpool track;        ///< the tracker's state after it
  SpoolDetection published;  ///< trackedDetection(raw, track): what goes out
  bool full_search = true;   ///< the flange was searched in the whole frame
};

/// Where the task expects the target spool: the slot the robot was sent to, from its navigation
/// (a map and the robot's pose in it). Which spool is "the target" is otherwise the detector's
/// rule, the one nearest the puller reference in the image (DESIGN.md §4), which a heading a few
/// degrees off, or a start nearer a neighbour's lane than the slot's, turns onto a neighbour.
struct TargetHint
{
  /// m, the target bore's front centre expected in the camera optical frame of the frame given
  cv::Point3d position;
  /// m, the target lies within this of `position`: the navigation's error; less than half the
  /// spacing of spools on the shelf, or a neighbour fits too
  double radius = 0.15;
};

/// The flange window of a bore's front centre at `p` (m, camera optical frame) with position
/// covariance `cov` (m^2) seen through `camera`'s pinhole (undistorted pixels), as
/// SpoolTracker::flangeWindow() describes it; nullopt when `p` is not ahead of the camera.
std::optional<FlangeWindow> flangeWindowAt(const Eigen::Vector3d& p, const Eigen::Matrix3d& cov,
                                           const CameraIntrinsics& camera, const DetectorParams& params);

/// A SpoolDetector followed by a SpoolTracker. While a track holds the spool the flange is
/// searched only in the tracker's window, with a whole-frame search every
/// track_full_search_interval frames, and again in the same frame when the window finds nothing.
class TrackingDetector
{
public:
  explicit TrackingDetector(const DetectorParams& params = DetectorParams());

  /// Both stages' parameters (validated by SpoolDetector; throws ParamError, keeping the old ones).
  void setParams(const DetectorParams& params);
  SpoolDetector& detector()
  {
    return detector_;
  }
  SpoolTracker& tracker()
  {
    return tracker_;
  }

  /// The frame `image` stamped `stamp` (s); `motion`: the camera's since the last frame, from
  /// odometry (SpoolTracker::update). With a `hint` (in this frame's camera frame) every search
  /// that would take the whole frame takes the hint's window instead (flangeWindowAt with a
  /// 3 sigma of `radius` each way), so no spool outside it is ever acquired, and a track that
  /// holds a spool outside it is dropped. Throws as SpoolDetector::detect().
  TrackedFrame process(const cv::Mat& image, PixelFormat format, double stamp,
                       const std::optional<CameraMotion>& motion = std::nullopt,
                       const std::optional<TargetHint>& hint = std::nullopt);

private:
  SpoolDetector detector_;
  SpoolTracker tracker_;
  int since_full_search_ = 0;
};

/// `raw` with the tracked values in place of the per-frame ones, as the node publishes them with
/// tracking on: position, distance (depth), range, lateral_offset, yaw (bearing of the bore's
/// front centre from the puller axis, atan of lateral offset over depth), axis, axis_angle,
/// axis_yaw and aligned from `track`; `detected` while a track holds the spool (tracking or
/// coasting). A coasting frame's rims are not this frame's: flange and hole circles zeroed and
/// hole_detected false. Without a track: `raw` with every number NaN and detected false.
SpoolDetection trackedDetection(const SpoolDetection& raw, const TrackedSpool& track, const GeometryParams& geometry);

}  // namespace spool_vision
