// Every tuning parameter of the detector in one plain struct, plus a table that names each key,
// its type, unit and allowed range. The YAML loader (CLI) and the ROS parameter loader (node)
// both walk this table, so a key is declared once and validated the same way everywhere.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "spool_vision/types.h"

namespace spool_vision
{
enum class FilterType
{
  kGaussian,
  kMedian,
  kAverage,
  kUnsharp,
  kNone
};
enum class BinarizeType
{
  kFixed,
  kOtsu,
  kNone
};
enum class MorphologyType
{
  kOpen,
  kDilate,
  kErode,
  kNone
};
enum class MatchMode
{
  kMcht,
  kCht
};
/// What makes a spool in mcht mode.
enum class SpoolEvidence
{
  kHole,  ///< a flange with a concentric hole (a round thing without a bore is not a spool)
  /// kHole, or where no flange has one, a strongly supported flange whose centre shows a disc of
  /// the bore's size darker or brighter than the face (a bore too small or faint to fit)
  kBore,
  kFlange  ///< the flange alone; the hole is reported when one passes (thesis: "BC or both")
};
/// A second flange search where the first finds no spool with a hole rim, or one farther from
/// the reference than its flange radius (SpoolDetector::detect()).
enum class FlangeRetry
{
  kNone,
  /// Either polarity: a glossy face under a lamp, or a grey face against a darker shelf, shows
  /// a rim brighter inside than out, which the dark search cannot see.
  kAnyPolarity
};
enum class YawMode
{
  kPinhole,
  kLinearFov
};
enum class ReferenceMode
{
  kPuller,
  kFixed
};

/// Pre-processing stage (thesis §3.3.2–3.3.3).
struct PreprocessParams
{
  FilterType filter = FilterType::kGaussian;
  double filter_sigma = 0.001875;  ///< rad, Gaussian sigma as a view angle (1.5 px at f = 800 px; also unsharp)
  int filter_kernel = 3;           ///< px, odd aperture of median / average
  double unsharp_amount = 0.8;     ///< gain of the unsharp mask
  /// The camera's encoding exponent: pixel = radiance^encoding_gamma (sRGB webcams about 0.45;
  /// 1 = linear). The bore's rim is placed in linear light (EdgeDetector::LinearLight).
  double encoding_gamma = 0.45;
  BinarizeType binarize = BinarizeType::kNone;
  double binarize_threshold = 0.35;  ///< fraction of full scale (thesis: 0.35)
  MorphologyType morphology = MorphologyType::kNone;
  int morphology_radius = 2;   ///< px, disk structuring element
  int min_component_area = 0;  ///< px, area opening of the binary image (0 = off)
};

/// Hough stage (thesis §3.3.4, Rule 1). Radii of 0 are derived from the distance range.
struct HoughParams
{
  double edge_threshold = 0.03;       ///< minimum gradient magnitude, fraction of full scale
  double hole_edge_threshold = 0.02;  ///< the same inside the hole window (the bore rim is faint)
  double sensitivity = 0.55;          ///< MATLAB-style: a flange needs (1 - sensitivity) of its rim
  double hole_sensitivity = 0.8;      ///< the same for the hole (a partly lit bore shows part of its rim)
  Polarity flange_polarity = Polarity::kDark;
  Polarity hole_polarity = Polarity::kAny;
  FlangeRetry flange_retry = FlangeRetry::kAnyPolarity;
  double flange_radius_min = 0.0;     ///< px, 0 = from distance_max
  double flange_radius_max = 0.0;     ///< px, 0 = from distance_min
  double hole_radius_min = 0.0;       ///< px, 0 = from distance_max
  double hole_radius_max = 0.0;       ///< px, 0 = from distance_min
  double min_visible_fraction = 0.3;  ///< ignore circles with less of their rim in the frame
  int max_candidates = 6;             ///< flange candidates kept per frame
  double edge_budget = 6.0;           ///< most edges kept per frame, per px of width + height
};

/// Concentric matcher (thesis Rule 2, Eq. 3.1).
struct MatcherParams
{
  MatchMode mode = MatchMode::kMcht;
  SpoolEvidence spool_evidence = SpoolEvidence::kBore;
  double flange_only_score = 0.85;  ///< spool_evidence bore: least rim score of a flange without a hole rim
  double bore_contrast = 0.05;      ///< spool_evidence bore: least bore/face contrast, fraction of full scale
  double weak_hole_score = 0.55;    ///< a hole rim scoring below this counts only when its disc shows too
  /// The same on a flange cut by the frame border (SpoolDetector::kCutFlangeVisibleFraction)
  double cut_flange_hole_score = 0.7;
  double concentric_tolerance = 0.005;  ///< rad, |hole centre - flange centre| per axis (4 px at f = 800 px)
  double hole_ratio_tolerance = 0.35;   ///< relative deviation from hole/flange diameter ratio
  double max_view_angle = 0.44;         ///< rad, widest view of the flange off its axis, sideways (~25 deg)
  double max_view_pitch = 0.05;         ///< rad, the same up or down (~3 deg)
};

/// Spool, camera and alignment geometry (thesis §3.4).
struct GeometryParams
{
  double flange_diameter = 0.35;  ///< m
  double hole_diameter = 0.036;   ///< m
  double hub_length = 0.2;        ///< m, front flange face to back flange face
  /// m, the longest the bore may be (spools differ: about 20 cm). `aligned` checks the puller at
  /// the bore's front and this far along its axis; a straight bore's miss is largest at an end, so
  /// every bore up to this long is covered. 0 = the front alone (the thesis)
  double bore_length_max = 0.22;
  double axis_height_tolerance = 0.1;    ///< m, spool axis off the puller's height (camera frame y)
  double puller_diameter = 0.031;        ///< m
  double distance_min = 0.45;            ///< m, nearest working distance (sets the largest radius)
  double distance_max = 1.2;             ///< m, farthest working distance (sets the smallest radius)
  double fallback_focal_length = 200.0;  ///< px at 120 image rows, used without camera info
  YawMode yaw_mode = YawMode::kPinhole;
  double field_of_view = 1.0471975511965976;  ///< rad, diagonal FOV for linear_fov yaw (60 deg)
  ReferenceMode reference_mode = ReferenceMode::kPuller;
  double reference_x = 80.0;                      ///< px, fixed reference (thesis: 80 at 160x120)
  double reference_y = 50.0;                      ///< px, fixed reference (thesis: 50 at 160x120)
  double puller_offset_x = 0.0;                   ///< m, puller axis from the camera, camera frame x (right)
  double puller_offset_y = 0.06;                  ///< m, puller axis from the camera, camera frame y (down)
  double overlap_tolerance = 0.00375;             ///< rad, Rule 3 window around the reference (3 px at f = 800)
  double aligned_max_yaw = 0.004363323129985824;  ///< rad (0.25 deg)
  double aligned_distance_min = 0.5;              ///< m
  double aligned_distance_max = 0.6;              ///< m
  /// m, taken off t_f for `aligned`: the puller's measured miss must clear the bore by this much
  /// (at 50-60 cm the miss is measured within ~0.1 mm, and a frame on the edge must not pass)
  double aligned_margin = 0.0001;
  /// rad, `aligned` only where one pixel subtends at most this (1 / fy): from a coarser image the
  /// spool axis is too uncertain to clear t_f over the bore (1.25 mrad at 640x480 passes)
  double aligned_max_pixel_angle = 0.0015;
};

/// Following one spool over the approach (SpoolTracker, DESIGN.md §8).
/// How a followed spool is measured in the frames between whole-frame searches
/// (SpoolTracker::flangeWindow(), SpoolDetector::detect()).
enum class TrackMeasurement
{
  /// Moving edges along the flange rim the track predicts (MovingEdges), the bore then fitted at
  /// its known size where the track puts it: only the pixels on the rim's normals and about the
  /// bore are read.
  kMovingEdges,
  /// A Hough search of the flange in the predicted window, whose square is preprocessed whole.
  kWindow
};

struct TrackerParams
{
  /// m/s^2, white-noise acceleration of the bore's front centre relative to the camera (the
  /// robot speeding up, braking, turning): the process noise of the constant-velocity model
  double acceleration = 0.3;
  double axis_drift = 0.003;  ///< rad/sqrt(s), random walk of the spool axis seen from the camera
  /// relative 1 sigma of the camera motion the robot's odometry gives (CameraMotion): of the
  /// distance driven and of the angle turned between two frames
  double odometry_noise = 0.05;
  /// rad, 1 sigma of how level the spools lie relative to the camera (a shelf board's tilt, the
  /// camera mount's pitch calibration): > 0 takes the axis's pitch as level_pitch with this
  /// uncertainty instead of measuring it from the rim, whose pitch is biased by 0.1-0.5 deg
  /// (docs/closed_loop.md); 0 = measure it from the rim (a shelf that is not level). The default
  /// (0.1 deg) is the job's: spools lying on a level board, the camera mounted level on the lift
  double level_pitch_sigma = 0.00175;
  /// the slope y/z a level spool's axis shows in the camera optical frame (the camera tilted
  /// down by t: tan t); used when level_pitch_sigma > 0
  double level_pitch = 0.0;
  /// Mahalanobis distance of a detection's position from the prediction beyond which it is
  /// refused (not fused, counted): 4 keeps 99.6% of true detections (3 degrees of freedom)
  double gate = 4.0;
  /// frames without a fused detection before the track is lost (none for a track with fewer than
  /// confirm_frames fused frames)
  int max_coast = 5;
  /// frames in a row the filtered state must clear the bore for aligned; also the fused frames a
  /// track needs before it is searched in a window, coasts or follows a rib ring
  int confirm_frames = 3;
  /// aligned needs each of the puller's misses plus this many standard deviations within t_f
  double aligned_sigma = 3.0;
  /// rad: tracked aligned only where one pixel subtends at most this (1 / fy; 320x240: 0.0025,
  /// 160x120: 0.005). From 320x240 up the filter's 3 sigma decides: the closed loop there
  /// (docs/closed_loop.md) inserts 196 of 200 untuned trials with no collision since a cut rim's
  /// depth no longer comes out 6% long (SpoolGeometry's second start); 0.0015 keeps it to 640x480.
  double aligned_max_pixel_angle = 0.003;
  double noise_scale = 1.0;  ///< multiplies the measured error model's sigmas (docs/error_model.md)
  /// frames: while tracking the flange is searched in the predicted window, and in the whole
  /// frame every this many frames (1 = always the whole frame)
  int full_search_interval = 10;
  /// how the flange is measured in the frames between whole-frame searches
  TrackMeasurement measurement = TrackMeasurement::kMovingEdges;
};

struct DetectorParams
{
  PreprocessParams preprocess;
  HoughParams hough;
  MatcherParams matcher;
  GeometryParams geometry;
  TrackerParams tracker;
};

/// A bad parameter: names the key and what it may be.
class ParamError : public std::runtime_error
{
public:
  ParamError(const std::string& key, const std::string& what)
    : std::runtime_error("parameter '" + key + "': " + what), key_(key)
  {
  }
  const std::string& key() const
  {
    return key_;
  }

private:
  std::string key_;
};

using ParamValue = std::variant<bool, int, double, std::string>;

enum class ParamType
{
  kInt,
  kDouble,
  kChoice
};

/// One row of the parameter table.
struct ParamSpec
{
  std::string key;
  ParamType type;
  double min_value;                  ///< inclusive, numeric keys
  double max_value;                  ///< inclusive, numeric keys
  std::vector<std::string> choices;  ///< allowed words, choice keys
  std::string unit;
  std::string doc;
  std::function<ParamValue(const DetectorParams&)> get;
  std::function<void(DetectorParams&, const ParamValue&)> set;  ///< value already checked and typed

  /// Human-readable allowed range, e.g. "[0, 1]" or "one of gaussian|median".
  std::string allowed() const;
};

/// The table, in the order the YAML files and the README list the keys.
const std::vector<ParamSpec>& paramSpecs();

/// Finds a key's row, nullptr if the key is unknown.
const ParamSpec* findParamSpec(const std::string& key);

/// Checks `value` against the key's type and range and stores it. Throws ParamError.
void setParam(DetectorParams& params, const std::string& key, const ParamValue& value);

/// Checks relations between keys (min < max and the like). Throws ParamError.
void validateParams(const DetectorParams& params);

/// Renders a value the way the YAML files write it.
std::string formatParamValue(const ParamValue& value);

}  // namespace spool_vision
