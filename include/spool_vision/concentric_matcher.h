// Stage 3: the MCHT rule (thesis Eq. 3.1, Rule 2) and target selection.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
#include "spool_vision/hough_accumulator.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// A flange and, if one passed the rule, its hole.
struct SpoolMatch
{
  Circle flange;
  std::optional<Circle> hole;
};

class ConcentricMatcher
{
public:
  /// `spool` gives the hole/flange ratio and the hub length; `camera` turns the angular
  /// tolerances into pixels (times fy) and sizes the perspective allowances.
  ConcentricMatcher(const MatcherParams& params, const GeometryParams& spool, const CameraIntrinsics& camera);

  /// How far (px; width along x, height along y) a concentric hole's centre may lie from
  /// `flange`'s fitted centre. A flange seen at an angle phi projects to an ellipse whose centre
  /// is pushed off the projected disc centre by about r^2/f * tan(phi) (the near half looks
  /// bigger); the hole is small enough to sit on the true centre. The spool axis is horizontal,
  /// so phi reaches max_view_angle sideways (tens of pixels at 50 cm and 640x480) but only
  /// max_view_pitch up or down, which keeps the window small where it need not be large.
  cv::Size2d centreTolerance(const Circle& flange) const;

  /// The hole radius (px) `flange`'s size implies: the known hole/flange diameter ratio.
  double holeRadius(const Circle& flange) const
  {
    return ratio_ * flange.r_vertical;
  }

  /// concentric_tolerance in px for this camera.
  double tolerancePx() const
  {
    return tolerance_px_;
  }

  /// The spool's back flange as this camera sees it (no back flange without a camera or in
  /// cht mode).
  const BackFlange& backFlange() const
  {
    return back_;
  }

  /// How far (px) the spool's true centre can lie outward of `flange`'s fitted centre along x
  /// (width) and y (height), away from the principal point. An oblique rim fit follows the
  /// front and back flanges' joint silhouette (see BackFlange) and lands between the two discs;
  /// at worst it is the back disc itself, whose depth Z + L = f R / r puts the front centre
  /// (fit - principal point) * L r / (f R) further out.
  cv::Size2d silhouetteShift(const Circle& flange) const;

  /// How far (px, left or right: the sign is not known from the ellipse alone) the spool's axis
  /// shows from `flange`'s ellipse centre when its rim is narrower than tall: a spool turned by
  /// psi, cos(psi) = r_horizontal / r_vertical, has its ellipse centre r_v^2 / f sin(psi)
  /// cos(psi) off the projected centre (9 px for a 20 degree turn at 1 m and 640x480). 0 for a
  /// round rim.
  double axisShift(const Circle& flange) const;

  /// How much larger than `flange` the front flange can be: (Z + L) / Z = 1 + L r / (f R) when
  /// the fit is the back disc; 1 without a back flange.
  double backToFront(const Circle& flange) const;

  /// True when a rim fit `fit` can be the joint silhouette of the front flange rim `front` and
  /// its back flange: its centre between the two discs' centres (give or take centreTolerance())
  /// and its radius between theirs (give or take 10%). A rim measured again about a hole must
  /// explain the fit that led to it; otherwise the "hole" was some other round mark.
  bool explainsFit(const Circle& front, const Circle& fit) const;

  /// Narrows `search` to where the hole of `flange`'s spool can be: centres in the concentric
  /// window widened outward by silhouetteShift() (and inside an image of `image_size`: a spool
  /// whose axis is out of view is not in front of the robot), radii around the size the flange
  /// implies (up to the front flange's when the fit is the back one). A hole found there but
  /// not accept()ed shows where to measure the front rim again. False when nothing can pass.
  bool narrowHoleSearch(const Circle& flange, cv::Size image_size, HoughSearch& search) const;

  /// The least fraction of a hole's rim inside the image for accepts().
  static constexpr double kMinHoleVisibleFraction = 0.9;

  /// True when `hole` may belong to `flange`: in mcht mode it is (nearly) whole in the image, its
  /// centre lies within centreTolerance() and its radius fits the known ratio; in cht mode always.
  bool accepts(const Circle& flange, const Circle& hole) const;

  /// The hole for `flange` among `holes`, if any passes: in mcht mode the one with the least
  /// distance (px) from where the axis shows (the flange centre moved by axisShift() either way)
  /// plus radius error (px), in cht mode the strongest (the thesis baseline has no pairing rule).
  std::optional<Circle> matchHole(const Circle& flange, const std::vector<Circle>& holes) const;

  /// A rim score from which a rim counts as whole: real rims score 0.8-1, circles made of arcs
  /// of several objects 0.2-0.6.
  static constexpr double kSolidRimScore = 0.8;
  /// How far a candidate centred at `centre` (px) is from being the target: its distance from
  /// the `reference` pixel (spools on one shelf share a row, so this orders them by |bearing|,
  /// the target rule of DESIGN.md §5; the vertical part keeps a circle far above the puller from
  /// winning), divided by its rim `score` relative to kSolidRimScore (at most 1): a weak circle
  /// must be nearer in proportion to its missing support, two solid rims are ordered by distance
  /// alone.
  static double targetCost(const cv::Point2d& centre, double score, const cv::Point2d& reference);
  /// Removes from `flanges` each circle that encloses a smaller one (of `flanges` or `others`),
  /// off its centre by more than a tenth of its radius, that scores at least kSolidRimScore and
  /// more than it: arcs of shelf boards and neighbours close such a ghost around a real rim,
  /// while nothing solid sits off centre inside a spool's own front rim (its bore is concentric).
  static void dropEnclosingGhosts(std::vector<Circle>& flanges, const std::vector<Circle>& others = {});
  /// Indices of `flanges` by targetCost(), lowest first: the order in which candidates are tried
  /// as the target (the robot wants the spool in front of the puller). Reuses `order`'s memory.
  static void orderByReference(const std::vector<Circle>& flanges, const cv::Point2d& reference,
                               std::vector<std::size_t>& order);

private:
  MatcherParams params_;
  double ratio_;         ///< hole / flange diameter
  double focal_length_;  ///< px (fy)
  double tolerance_px_;  ///< concentric_tolerance in px
  BackFlange back_;
};

}  // namespace spool_vision
