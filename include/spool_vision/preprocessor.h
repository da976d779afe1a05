// Stage 1: grayscale, noise filter, optional binarization, morphology and area opening.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// Turns a camera frame into the 8-bit single-channel image the Hough stage reads.
/// Buffers are members so steady-state processing does not allocate.
class Preprocessor
{
public:
  /// `focal_length` (px, fy) turns the angular filter_sigma into pixels.
  Preprocessor(const PreprocessParams& params, double focal_length);

  void setParams(const PreprocessParams& params, double focal_length);
  const PreprocessParams& params() const
  {
    return params_;
  }

  /// Runs every stage. `out` is CV_8UC1 of the input's size. Throws std::invalid_argument
  /// when the matrix type does not fit `format` or the image is empty.
  void process(const cv::Mat& image, PixelFormat format, cv::Mat& out);
  /// process() inside `region` (px of the frame) only, for a search window: `out` is the frame's
  /// size, with the same pixels as process() inside `region` and 0 outside it; gray() is this
  /// frame's within filterReach() px of `region`. The thesis' binarize path (whose morphology and
  /// area opening see whole components) always processes the whole frame.
  void process(const cv::Mat& image, PixelFormat format, cv::Mat& out, const cv::Rect& region);
  /// px beyond a pixel that the noise filter reads to compute it.
  int filterReach() const;

  /// The stages one at a time (each `out` may alias nothing else).
  /// toGray() and toBgr() run on the calling thread (cv::cvtColor over the frame as one row:
  /// OpenCV's parallel_for_ keeps a one-row range in place), with the same pixels as a plain call.
  static void toGray(const cv::Mat& image, PixelFormat format, cv::Mat& gray);
  /// `image` of `format` as 8-bit BGR in `bgr` (always a copy, for drawing on; mono16 scaled as
  /// toGray() scales it). Throws std::invalid_argument as process() does.
  static void toBgr(const cv::Mat& image, PixelFormat format, cv::Mat& bgr);
  void filter(const cv::Mat& gray, cv::Mat& out);
  void binarize(const cv::Mat& gray, cv::Mat& out) const;
  void morphology(const cv::Mat& binary, cv::Mat& out) const;
  /// Removes 8-connected foreground components smaller than min_component_area.
  void areaOpening(const cv::Mat& binary, cv::Mat& out);

  /// The last process()'s gray frame before filtering (CV_8UC1).
  const cv::Mat& gray() const
  {
    return gray_;
  }
  /// Linear light of each gray level, (level / 255)^(1 / encoding_gamma), 0..1.
  const std::array<float, 256>& linearLight() const
  {
    return linear_light_;
  }

private:
  void gaussian(const cv::Mat& gray, cv::Mat& out);

  PreprocessParams params_;
  std::vector<std::uint16_t> kernel_;  ///< Gaussian taps, 8.8 fixed point, summing to 256
  std::array<float, 256> linear_light_{};
  cv::Mat rows_;  ///< the Gaussian's horizontal pass, the frame's size (a region uses its corner)
  std::vector<std::uint16_t> line_;
  std::vector<std::uint32_t> acc_;
  cv::Mat structuring_element_;
  cv::Mat gray_, filtered_, binary_, morph_, blur_;
  cv::Mat labels_, stats_, centroids_;
};

}  // namespace spool_vision
