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
  /// `focal_length` (px) sizes the perspective allowance of centreTolerance(); 0 = none.
  ConcentricMatcher(const MatcherParams& params, double hole_to_flange_ratio, double focal_length = 0.0);

  /// How far (px; width along x, height along y) a concentric hole's centre may lie from
  /// `flange`'s fitted centre. A flange seen at an angle phi projects to an ellipse whose centre
  /// is pushed off the projected disc centre by about r^2/f * tan(phi) (the near half looks
  /// bigger); the hole is small enough to sit on the true centre. The spool axis is horizontal,
  /// so phi reaches max_view_angle sideways (tens of pixels at 50 cm and 640x480) but only
  /// max_view_pitch up or down, which keeps the window small where it need not be large.
  cv::Size2d centreTolerance(const Circle& flange) const;

  /// Narrows `search` to where a hole accept() takes can be: centres in the concentric window
  /// (and inside an image of `image_size`: a spool whose axis is out of view is not in front of
  /// the robot), radii around the size the flange implies. False when nothing can pass.
  bool narrowHoleSearch(const Circle& flange, cv::Size image_size, HoughSearch& search) const;

  /// True when `hole` may belong to `flange`: in mcht mode its centre lies within
  /// centreTolerance() and its radius fits the known ratio; in cht mode always.
  bool accepts(const Circle& flange, const Circle& hole) const;

  /// The hole for `flange` among `holes`, if any passes: in mcht mode the one nearest the
  /// flange centre, in cht mode the strongest (the thesis baseline has no pairing rule).
  std::optional<Circle> matchHole(const Circle& flange, const std::vector<Circle>& holes) const;

  /// Indices of `flanges`, nearest `reference` first, the distance divided by the rim score:
  /// the order in which candidates are tried as the target (the robot wants the spool in front
  /// of the puller). Reuses `order`'s memory.
  static void orderByReference(const std::vector<Circle>& flanges, const cv::Point2d& reference,
                               std::vector<std::size_t>& order);

private:
  MatcherParams params_;
  double ratio_;
  double focal_length_;
};

}  // namespace spool_vision
