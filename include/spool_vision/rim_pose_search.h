// Stage 3b: an oblique flange's rim found about its bore. The Hough search votes for circles, and
// seen 25-40 deg off its axis a flange is an ellipse 0.77-0.9 as wide as it is high: the best
// circle then runs along what lies beside the rim (the back flange's silhouette, a touching
// neighbour) and the pose fitted to it is wrong by 10-15% of depth. About the bore (the centre of
// the face), the rim is a circle of the flange's diameter whose depth and axis are unknown: poses
// are tried, each measured by moving edges (MovingEdges), and the best refined by the 3-D rim fit
// (SpoolGeometry::fitRimPose).
#pragma once

#include <array>
#include <cstddef>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/moving_edges.h"
#include "spool_vision/spool_geometry.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// A flange rim measured at one pose.
struct RimPoseFit
{
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  cv::Point3d position{kNaN, kNaN, kNaN};  ///< m, the bore's front centre, camera optical frame
  cv::Vec3d axis{kNaN, kNaN, kNaN};        ///< unit, the spool axis (into the spool), camera optical frame
  Circle rim;                              ///< undistorted px: the rim model of MovingEdges' fit at the starting pose
  /// Fraction of the rim's samples inside the frame whose edge lies within the 3-D fit's band
  /// (SpoolGeometry::fitRimPose's support over MovingEdges::samplesInFrame()), 0..1
  double support = 0.0;
  std::vector<cv::Point2f> edges;  ///< the edges on the rim (undistorted px), for the pose
};

class RimPoseSearch
{
public:
  /// The camera of the frames (MovingEdges::setCamera). Throws std::invalid_argument on invalid
  /// intrinsics.
  void setCamera(const CameraIntrinsics& camera);
  /// MovingEdges::beginFrame() and endFrame(): a frame's gray levels kept over calls. search()
  /// keeps them over its own poses in any case.
  void beginFrame()
  {
    moving_edges_.beginFrame();
  }
  void endFrame()
  {
    moving_edges_.endFrame();
  }

  /// The rim of the flange whose bore's front centre shows at `bore` (undistorted px), measured
  /// from the pose (`position`, m; `axis`, unit; camera optical frame; a NaN axis faces the
  /// camera): moving edges along that pose's rim (`search`), then fitRimPose() on them from that
  /// pose, about the bore's ray. False (fit untouched) when either finds too little. Throws
  /// std::invalid_argument when the image does not fit `format`.
  bool measure(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const cv::Point2d& bore,
               const cv::Point3d& position, const cv::Vec3d& axis, const RimSearch& search, RimPoseFit& fit);

  /// The best-supported rim about `bore` over poses on its ray: depths from `nearest` to
  /// `farthest` (m), kDepthStep apart, and level axes (no pitch: spools lie on a level board)
  /// turned up to kMaxViewAngle either way off the line of sight, kYawStep apart. Each is measured
  /// by moving edges (kCoarseSamples of them); the kRefined whose edges cover most of the rim are
  /// fitted in 3-D (measure(); where the fit about the bore's ray fails, with the rim's centre
  /// fitted too, within kBoreOffCentre of its size of the bore: a dark bore seen far off its axis is
  /// measured a few px off its centre) and the one with the most support wins; the nearest pose
  /// scoring kOuterCoarseShare of the best is fitted too and replaces it where it is outside() it;
  /// then outermost() from it. Where none of the kRefined fits, the next `fallback` best covered
  /// poses are fitted (a rim seen 25-40 deg off its axis borders its own back flange along a third
  /// of it and covers 0.6-0.8 of its coarse samples, a rib ring inside it all of them, and rib
  /// rings fail the 3-D fit). With `in_view_retry`, where none of those fits either, the kRefined
  /// are measured again with as many samples inside the frame as a whole rim has
  /// (RimSearch::samples_in_view), and so are the rims outside the one found: a face the frame cuts
  /// near the camera keeps too few for the 3-D fit otherwise. `nearest` and `farthest` positive,
  /// nearest <= farthest. False when none fits.
  bool search(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const cv::Point2d& bore,
              double nearest, double farthest, const RimSearch& search, RimPoseFit& best, std::size_t fallback = 0,
              bool in_view_retry = false);
  /// search() over the level axes within `half_range` (rad) of `axis_yaw` (rad, the axis's turn
  /// about the camera's y axis from the optical axis: atan2(x, z), camera optical frame),
  /// kYawStep apart, those seen at most kWidestViewAngle off the line of sight to `bore`: a
  /// neighbour of a spool whose axis was measured, seen farther off its axis than search() tries.
  /// The kRefinedAbout best covered poses are measured in full; `fallback` as search()'s; the
  /// centre fitted within `off_centre` of the rim's size where the fit about the bore's ray fails
  /// (a share; search()'s kBoreOffCentre by default).
  bool searchAbout(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const cv::Point2d& bore,
                   double nearest, double farthest, const RimSearch& search, double axis_yaw, double half_range,
                   RimPoseFit& best, std::size_t fallback = 0, double off_centre = kBoreOffCentre);

  /// How many samples of the last measure()'s rim had their whole normal in the frame.
  std::size_t samplesInFrame() const
  {
    return moving_edges_.samplesInFrame();
  }

  /// 40 deg: the widest view off the spool axis a pose is taken at (SpoolGeometry::measure).
  static constexpr double kMaxViewAngle = 0.6981317007977318;
  /// 60 deg: the widest view searchAbout() takes a pose at (the flange's ellipse half as wide as high).
  static constexpr double kWidestViewAngle = 1.0471975511965976;
  /// 10 deg: the moving edges' reach covers the rim's shift between neighbouring axes.
  static constexpr double kYawStep = 0.17453292519943295;
  /// 7% of depth between poses: within the moving edges' reach (6% of the rim's size) either way.
  static constexpr double kDepthStep = 1.07;
  static constexpr std::size_t kRefined = 4;
  /// searchAbout()'s: a narrow ellipse's coarse poses cover its rim alike (0.88-1.0 over 20 deg and
  /// 15% of depth: oblique seed 19 #124), and the best four can all miss it; with eight, 9 more
  /// targets seen 45-57 deg off their axes were found on 1,100 oblique frames (seeds 7-41).
  static constexpr std::size_t kRefinedAbout = 8;
  /// How far (a share of the rim's radius, px) the search's rim centre may lie off the bore's where
  /// the fit about the bore's ray fails (SpoolGeometry::fitRimPose's centre_reach). Not in measure(),
  /// which checks a rim about a measured bore (a rib ring fitted off its bore would pass).
  static constexpr double kBoreOffCentre = 0.05;
  /// A larger rim about the same axis with this share of the best rim's support is the flange,
  /// the best one a rib ring on its face (outermost()).
  static constexpr double kOuterSupport = 0.7;
  /// Rib rings lie at 0.6 of the flange's size and more: a rim is looked for out to 1.7 times one.
  static constexpr double kInnerRing = 1.7;
  /// The nearest coarse pose with this share of the best coarse score is fitted as well: on the
  /// oblique sets of seeds 7-97 at 320x240 to 1280x720, 2 more targets (the rib ring chosen on the
  /// mirrored axis) and a rib 19% deep at 160x120 replaced by its rim, no target lost; at 0.7 one
  /// target fewer found, at 0.9 one lost.
  static constexpr double kOuterCoarseShare = 0.8;
  /// Samples of each pose's rim in the scan (the kRefined are measured at MovingEdges' full count)
  static constexpr int kCoarseSamples = 32;

private:
  /// search()'s scan over the axes centre_yaw + k kYawStep, |k| <= turns (rad, level), those within
  /// kWidestViewAngle of the line of sight, the `refined` (at most max(kRefined, kRefinedAbout))
  /// best covered measured in full, where none fits the next `fallback`, and where none of those
  /// does either and `in_view_retry`, the `refined` again densely in view (search()).
  bool searchYaws(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const cv::Point2d& bore,
                  double nearest, double farthest, const RimSearch& search, double centre_yaw, int turns,
                  std::size_t refined, std::size_t fallback, double off_centre, bool in_view_retry, RimPoseFit& best);
  /// measure(), where the fit about the bore's ray fails with the centre also fitted within
  /// `off_centre` of the rim's size of the bore (0: not).
  bool measurePose(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const cv::Point2d& bore,
                   const cv::Point3d& position, const cv::Vec3d& axis, const RimSearch& search, double off_centre,
                   RimPoseFit& fit);

  /// A pose of searchYaws()' scan and how much of its rim the coarse look covered.
  struct CoarsePose
  {
    double score = 0.0;  ///< the coarse look's share of the rim's samples on an edge
    double depth = 0.0;  ///< m, along the bore's ray
    double yaw = 0.0;    ///< rad, the level axis's atan2(x, z)
  };

  /// measurePose() at the coarse `pose` (its score positive) on `bore`'s `ray` (z = 1): true where
  /// a rim was fitted before (`found`) or now; the fit replaces `best` where none was found before
  /// or it has more support.
  bool fitPose(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const cv::Point2d& bore,
               const cv::Point3d& ray, const CoarsePose& pose, const RimSearch& search, double off_centre, bool found,
               RimPoseFit& best);
  /// Whether `outer` replaces `inner` as the flange: nearer by half a depth step (the moving edges
  /// reach back to the inner rim from one step out) and with kOuterSupport of its support.
  static bool outside(const RimPoseFit& outer, const RimPoseFit& inner);
  /// The flange is the outermost rim about its bore, and a rib ring on its face is a whole circle
  /// about the bore too: rims about `best`'s axis are measured outwards, kDepthStep apart, out to
  /// kInnerRing times its size, and the outermost with kOuterSupport of `best`'s support replaces it.
  void outermost(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const cv::Point2d& bore,
                 const RimSearch& search, double off_centre, RimPoseFit& best);

  MovingEdges moving_edges_;
  /// Whether a rim measurePose() measured since searchYaws() began was MovingEdges::sparseInView()
  bool sparse_in_view_ = false;
  RimPoseFit candidate_;
  std::vector<CoarsePose> coarse_;  ///< searchYaws()'s poses, in the order scanned
  std::vector<CoarsePose> ranked_;  ///< searchYaws()'s poses, best covered first (its fallback)
};

}  // namespace spool_vision
