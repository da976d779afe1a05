// Stage 2 while a track holds the spool: the flange rim measured where the track predicts it, by
// moving edges (a 1-D search along the normal of each sample of the predicted rim, as ViSP's
// vpMeEllipse tracks an ellipse: Marchand, Chaumette, "Feature tracking for visual servoing
// purposes", Robotics and Autonomous Systems 52(1), 2005). Only the few thousand pixels on those
// normals are read: no whole-frame preprocessing, edge map or vote.
#pragma once

#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/types.h"

namespace spool_vision
{
/// How the edges are searched along each normal.
struct RimSearch
{
  double reach = 0.0;  ///< px (undistorted) either way along the normal
  /// kDark: the disc is darker than what lies outside it (the light rises outward), kBright the
  /// reverse, kAny either
  Polarity polarity = Polarity::kDark;
  /// the least gradient, as a fraction of full scale (edge_threshold: a 3x3 Sobel's 4 * 255)
  double threshold = 0.05;
  double sigma = 0.0;  ///< px, the Gaussian the profile is smoothed with along the normal (the detector's filter)
  /// At most this many samples of the rim (MovingEdges::kMaxSamples; a coarse look takes fewer)
  int max_samples = 96;
  /// max_samples counts the samples inside the frame: a rim cut by it is sampled more densely
  bool samples_in_view = false;
  /// > 0: the fit starts about the offset most edges agree on, not their median, and keeps edges
  /// within at most this share of the radius (at least 2 px) of the rim, however widely they
  /// scatter. For a prediction as sharp as a track's: a second edge beside the rim (a dark gap
  /// between spools, blur) is then never averaged in. 0: 3 MAD sigmas, however wide (a coarse
  /// pose's rim, whose shape is only roughly the one seen).
  double max_band_share = 0.0;
};

/// Finds a predicted rim in a frame by moving edges and fits the detector's rim model to it.
class MovingEdges
{
public:
  /// The camera of the frames (its K projects the prediction; its distortion places each normal
  /// in the raw frame). Throws std::invalid_argument on invalid intrinsics.
  void setCamera(const CameraIntrinsics& camera);

  /// Measures `prediction`'s rim in `image` (a frame of `format` from setCamera()'s camera):
  /// a sample every 5 px of the predicted rim (kMinSamples to search.max_samples, or that many in
  /// view with search.samples_in_view: up to 4x as many round a rim cut by the frame; the prediction's circle
  /// projected through the pinhole), each moved to the strongest edge of `search.polarity` within
  /// `search.reach` along its normal (the profile read bilinearly on two lines a px apart, smoothed
  /// by `search.sigma`; sub-pixel: a parabola through the gradient's peak). The rim is then the
  /// predicted one moved and scaled to those edges (least squares along the normals: its shape,
  /// the tracked axis's, is kept), the edges off it by more than 3 robust sigmas (at least 1 px)
  /// dropped, three times. `rim` (undistorted px): that rim as the detector's rim model
  /// (fitRimModel() of the prediction: centre, r, r_vertical, r_horizontal), its score the
  /// fraction of the samples inside the frame that lie on it, its visible_fraction
  /// visibleRimFraction()'s. False with fewer than kMinEdges on it, or a prediction not ahead of
  /// the camera. Throws std::invalid_argument when the image does not fit `format`.
  bool measure(const cv::Mat& image, PixelFormat format, const RimPrediction& prediction, const RimSearch& search,
               Circle& rim);

  /// The edges on the last measure()'s fit (undistorted px), for SpoolGeometry's rim pose.
  const std::vector<cv::Point2f>& rimEdges() const
  {
    return on_rim_;
  }
  /// How many of the last measure()'s samples had their whole normal inside the frame.
  std::size_t samplesInFrame() const
  {
    return in_frame_;
  }
  /// Whether the last measure() took fewer samples than its rim has at the sample spacing (capped
  /// by search.max_samples) and some of them lay outside the frame: sampled as densely in view as
  /// a whole rim (RimSearch::samples_in_view) it would have more inside.
  bool sparseInView() const
  {
    return sparse_in_view_;
  }
  /// The last successful measure()'s rim over its prediction: the scale of the fit (1 + e).
  double fittedScale() const
  {
    return scale_;
  }
  /// From now until endFrame(), measure() keeps the gray levels of the tiles of the frame its
  /// rims reach and reads them again for every later rim: a pose search measures dozens of rims on
  /// one frame. The caller promises that the pixels do not change until endFrame(); another
  /// buffer, size or format is noticed and converted afresh. Outside beginFrame()..endFrame(),
  /// each measure() converts what it reads anew. SpoolDetector holds every frame it searches.
  void beginFrame();
  /// Ends beginFrame(): the levels kept are forgotten.
  void endFrame();
  /// Whether beginFrame() holds a frame.
  bool holdsFrame() const
  {
    return holds_frame_;
  }

  /// The last measure()'s predicted rim (undistorted px), for overlays and tests.
  const std::vector<cv::Point2d>& predictedRim() const
  {
    return points_;
  }

  static constexpr int kMaxSamples = 96;
  static constexpr int kMinSamples = 24;
  static constexpr std::size_t kMinEdges = 12;

private:
  /// points_ and normals_: the prediction's rim through the pinhole, `count` samples.
  bool project(const RimPrediction& prediction, int count);
  /// found_ (undistorted px; NaN where no edge qualifies) and how many samples lay inside the frame.
  std::size_t searchNormals(const cv::Mat& image, PixelFormat format, const RimSearch& search);
  /// levels_ for `image`: kept where the frame held is the same (buffer, format, step, size),
  /// else sized for it with no tile converted.
  void keepLevelsOf(const cv::Mat& image, PixelFormat format);
  /// The tiles of levels_ that `region` (px, clipped to the frame) touches converted from `image`
  /// where not yet done.
  void convertTiles(const cv::Mat& image, PixelFormat format, const cv::Rect& region);
  /// on_rim_ and `rim`: the robust fit of found_.
  bool fit(cv::Size size, std::size_t in_frame, double max_band_share, Circle& rim);

  CameraIntrinsics camera_;
  std::vector<cv::Point2d> points_;   ///< predicted rim, undistorted px
  std::vector<cv::Point2d> normals_;  ///< unit, outward
  std::vector<cv::Point2d> found_;
  std::vector<cv::Point2f> on_rim_;
  std::vector<float> profile_, smoothed_, kernel_;
  std::vector<double> scratch_;
  // The frame's gray levels (CV_32F, as cv::cvtColor weighs the channels), filled in tiles of
  // kLevelTile px square as rims reach them: one rim reads a band of the frame, a pose search
  // dozens of bands over the same pixels.
  static constexpr int kLevelTile = 16;
  cv::Mat levels_;
  std::vector<unsigned char> level_tiles_;    ///< 1 where a tile of levels_ is converted, row-major
  const unsigned char* levels_of_ = nullptr;  ///< the frame levels_ are of (nullptr: none)
  bool holds_frame_ = false;
  PixelFormat levels_format_ = PixelFormat::kMono8;
  std::size_t levels_step_ = 0;
  std::size_t in_frame_ = 0;
  bool sparse_in_view_ = false;
  double scale_ = 1.0;
};

}  // namespace spool_vision
