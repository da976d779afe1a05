// The thesis debug overlay (red flange, blue hole, green reference cross, status text), drawn
// with OpenCV only so that the node and the command-line tools show the same picture.
#pragma once

#include <opencv2/core.hpp>

#include "spool_vision/types.h"

namespace spool_vision
{
/// Draws the overlay for `detection` onto a BGR 8-bit image in place.
void drawOverlay(cv::Mat& bgr, const SpoolDetection& detection);

/// A new BGR 8-bit copy of `image` (given in `format`) with the overlay; `image` is never
/// written, so it may be shared with other users of the frame. Throws std::invalid_argument on
/// an empty image or one whose type does not match `format`.
cv::Mat renderOverlay(const cv::Mat& image, PixelFormat format, const SpoolDetection& detection);

}  // namespace spool_vision
