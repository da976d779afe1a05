// Stage 3: the MCHT rule (thesis Eq. 3.1, Rule 2) and target selection.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
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
  ConcentricMatcher(const MatcherParams& params, double hole_to_flange_ratio);

  /// True when `hole` may belong to `flange`: in mcht mode its centre lies within the
  /// concentric tolerance on both axes and its radius fits the known ratio; in cht mode always.
  bool accepts(const Circle& flange, const Circle& hole) const;

  /// The hole for `flange` among `holes`, if any passes: in mcht mode the one nearest the
  /// flange centre, in cht mode the strongest (the thesis baseline has no pairing rule).
  std::optional<Circle> matchHole(const Circle& flange, const std::vector<Circle>& holes) const;

  /// The target among several flanges: the one whose centre is nearest `reference`.
  static std::optional<Circle> selectTarget(const std::vector<Circle>& flanges,
                                            const cv::Point2d& reference);

private:
  MatcherParams params_;
  double ratio_;
};

}  // namespace spool_vision
