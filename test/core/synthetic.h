// Drawn test scenes with exactly known circles (no renderer physics: the answers are the
// drawing parameters themselves).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/types.h"

namespace spool_vision::test
{
struct DrawnSpool
{
  double x;
  double y;
  double flange_r;
  double hole_r;  ///< 0 = no hole
};

struct SceneStyle
{
  int background = 170;
  int flange = 35;
  int hole = 235;
  double noise_sigma = 0.0;
  std::uint64_t seed = 1;
};

/// A spool whose flange face is fronto-parallel at `depth` m, `lateral` m right and `below` m
/// below the optical axis, seen by `camera` (thesis spool: 35 cm flange, 3.6 cm hole).
DrawnSpool spoolAt(const CameraIntrinsics& camera, double depth, double lateral, double below);

/// Blends a filled ellipse (semi-axes a, b along x and y turned by `tilt` rad from x towards y)
/// into `gray` by exact pixel coverage.
void fillEllipse(cv::Mat& gray, double x, double y, double a, double b, int value, double tilt = 0.0);

/// Draws the spools (anti-aliased, sub-pixel) on a uniform background, BGR 8-bit.
cv::Mat drawScene(cv::Size size, const std::vector<DrawnSpool>& spools, const SceneStyle& style = SceneStyle());

/// Same scene as a single-channel image.
cv::Mat drawSceneGray(cv::Size size, const std::vector<DrawnSpool>& spools, const SceneStyle& style = SceneStyle());

}  // namespace spool_vision::test
