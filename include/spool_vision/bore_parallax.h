// Stage 4b: the spool axis from the bore's parallax. Seen down a ~20 cm bore, its back opening
// lies inside the front rim's image only where the camera is on the bore's axis (thesis Fig. 3.3:
// the two rims share a centre only there); elsewhere the lit wall behind the spool shows through
// the overlap of the two openings, a bright lens inside the dark front rim. Where the lens lies
// tells where the back opening is, which moves ~3.8 px per degree of axis yaw at 55 cm and
// 640x480 (f = 800 px), against ~1.4 px for the flange rim's ellipse centre.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
#include "spool_vision/hough_accumulator.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// The lit lens inside a bore's front rim, measured in the undistorted image (px).
struct LensView
{
  cv::Point2d centroid;        ///< brightness-weighted centroid of the lit part, px
  double area = 0.0;           ///< lit area, px^2
  cv::Point2d region_centre;   ///< the disc measured: the front rim's centre, px
  double region_radius = 0.0;  ///< and its radius, px (the rim's less a blur margin)
};

/// The lens inside the front rim about `centre` with radius `radius` (undistorted px) of the
/// frame `light` reads (its gray frame must be CV_8UC1) taken through `camera`'s lens, in linear
/// light: sampled where the lens puts each undistorted pixel (linearLightAt()).
/// The disc is read 1 px plus 5% of its radius inside the rim (the rim's own blur), each pixel
/// weighted by a ramp over the middle half between the disc's 5th and 98th brightness
/// percentiles (a blurred step's half-way point in linear light stays on the edge). nullopt when the disc is under 4
/// px, its contrast under kMinLensContrast (a dark bore), or the lit part under 3% or over 97% of it. `samples` is
/// scratch.
std::optional<LensView> measureLens(const LinearLight& light, const CameraIntrinsics& camera, const cv::Point2d& centre,
                                    double radius, std::vector<float>& samples);

/// The overlap of two discs: its area (px^2) and centroid. Closed form: two circular segments
/// cut by the common chord, each with its centroid 2 c^3 / (3 A) from its circle's centre (c the
/// half chord, A the segment's area). Area 0 (centroid NaN) when they do not overlap.
struct DiscOverlap
{
  double area = 0.0;
  cv::Point2d centroid;
};
DiscOverlap discOverlap(const cv::Point2d& c1, double r1, const cv::Point2d& c2, double r2);

/// The spool axis's slopes (x/z, y/z, camera optical frame) and their covariance (rad^2, to
/// first order) from one frame's lens.
struct ParallaxAxis
{
  cv::Vec2d slopes;
  cv::Matx22d covariance;
};

/// 1-sigma pixel noise axisFromBoreParallax() propagates: the lens centroid, measured against
/// exact truth on rendered approaches through a webcam (0.06 px at 640x480) with a margin for
/// real texture, and the front rim's centre (docs/error_model.md: 0.14-0.17 px on the hard set).
constexpr double kLensCentroidSigmaPx = 0.1;
constexpr double kFrontCentreSigmaPx = 0.15;
/// 1-sigma of a bore's length relative to hub_length (spools differ by about +-2 cm in 20).
constexpr double kBoreLengthSpread = 0.06;
/// Least brightness span of a lit lens over the dark bore, fraction of full scale.
constexpr double kMinLensContrast = 0.1;

/// The axis whose back opening (a circle of hole_diameter, hub_length behind the front one along
/// the axis) puts the lens where `lens` shows it, for a front opening centred at `front_centre`
/// (undistorted px) at `depth` (m, camera optical frame). Newton on the back opening's image
/// centre (discOverlap() of the two openings' images, the front one shrunk to lens.region_radius
/// as measured), then the axis through the two centres in 3D. The covariance propagates
/// kLensCentroidSigmaPx, kFrontCentreSigmaPx and kBoreLengthSpread (numerically): the yaw is
/// sharp wherever the lens shows, the pitch is not when the camera sits above the bore (the
/// vertical parallax is then mostly the bore's length). nullopt when Newton does not converge or
/// the measured lit area differs from the model's by more than a third (a lamp's reflection, the
/// puller rod across the bore).
std::optional<ParallaxAxis> axisFromBoreParallax(const GeometryParams& geometry, const CameraIntrinsics& camera,
                                                 const cv::Point2d& front_centre, double depth, const LensView& lens);

}  // namespace spool_vision
