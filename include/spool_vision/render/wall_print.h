// Prints on the back wall that behave like what a real webcam sees around a shelf: a whiteboard
// with writing, a photograph, printed cartons, a pallet rack, shrink wrap (issue 28: real frames
// have far more texture than flat renders, and texture starves an edge budget). The textures are
// generated here from a seed: no third-party images.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace spool_vision
{
enum class PrintKind
{
  kWhiteboard,  ///< light board, marker handwriting, hand-drawn circles and arrows, smudges
  kPhotograph,  ///< a poster: a busy colour photograph (shapes at every scale, some out of focus)
  kCartons,     ///< stacked brown cartons: seams, logos, lines of print, barcodes, tape
  kRack,        ///< a pallet rack: punched uprights, beams, stock on the shelves
  kShrinkWrap,  ///< cartons under stretch film: bright streaks and glints over the print
};

/// A rectangular print hung flat on the back wall (world frame of spool_renderer.h: x right,
/// y up, m).
struct WallPrint
{
  PrintKind kind = PrintKind::kWhiteboard;
  double x = 0.0;       ///< m, centre
  double y = 1.0;       ///< m, centre height above the floor
  double width = 0.5;   ///< m
  double height = 0.4;  ///< m
  std::uint64_t seed = 1;
};

/// A print's reflectance, generated once, sampled by the ray caster.
class PrintTexture
{
public:
  /// m per texel of the finest level: finer than a 640x480 pixel on the wall at working range.
  static constexpr double kTexel = 0.0015;

  explicit PrintTexture(const WallPrint& print);

  /// Whether the wall point (x, y) (m) lies on the print.
  bool contains(double x, double y) const;

  /// Linear BGR reflectance (0-1) at the wall point (x, y) (m), averaged over about `footprint`
  /// (m, the pixel's size on the wall) from a mip pyramid, so that fine print far away blends
  /// instead of aliasing. Points off the print give the nearest edge texel.
  cv::Vec3d reflectance(double x, double y, double footprint) const;

private:
  WallPrint print_;
  std::vector<cv::Mat> levels_;  ///< CV_32FC3, level i has kTexel * 2^i m per texel; row 0 at the top
};

}  // namespace spool_vision
