#include "spool_vision/detector_params.h"

#include <cmath>
#include <sstream>

namespace spool_vision
{
namespace
{
const char* const kPolarities[] = {"dark", "bright", "any"};

std::string formatNumber(double v)
{
  std::ostringstream os;
  os << v;
  return os.str();
}

// Builders keep each row of the table to one line: key, member, range, unit, doc.
template <typename Member>
ParamSpec number(const std::string& key, Member member, double lo, double hi, const std::string& unit,
                 const std::string& doc)
{
  using T = std::remove_reference_t<decltype(member(std::declval<DetectorParams&>()))>;
  static_assert(std::is_same_v<T, int> || std::is_same_v<T, double>, "numeric keys are int or double");
  const ParamType type = std::is_same_v<T, int> ? ParamType::kInt : ParamType::kDouble;
  return ParamSpec{key,
                   type,
                   lo,
                   hi,
                   {},
                   unit,
                   doc,
                   [member](const DetectorParams& p) -> ParamValue { return member(p); },
                   [member](DetectorParams& p, const ParamValue& v)
                   {
                     if constexpr (std::is_same_v<T, int>)
                       member(p) = std::get<int>(v);
                     else
                       member(p) = std::get<double>(v);
                   }};
}

template <typename Enum, typename Member>
ParamSpec choice(const std::string& key, Member member, std::vector<std::string> words, const std::string& doc)
{
  auto names = words;
  return ParamSpec{key,
                   ParamType::kChoice,
                   0,
                   0,
                   std::move(words),
                   "",
                   doc,
                   [member, names](const DetectorParams& p) -> ParamValue
                   { return names.at(static_cast<size_t>(member(p))); },
                   [member, names](DetectorParams& p, const ParamValue& v)
                   {
                     const auto& word = std::get<std::string>(v);
                     for (size_t i = 0; i < names.size(); ++i)
                       if (names[i] == word)
                         member(p) = static_cast<Enum>(i);
                   }};
}

#define FIELD(path)    \
  [](auto& p) -> auto& \
  {                    \
    return p.path;     \
  }

// The table itself, one row per key in the order of the YAML files: longer than a function
// should be, because splitting it would scatter the one list every other copy is checked against.
std::vector<ParamSpec> buildSpecs()
{
  const std::vector<std::string> polarity(std::begin(kPolarities), std::end(kPolarities));
  return {
      // Pre-processing (thesis §3.3.2-3.3.3)
      choice<FilterType>("filter", FIELD(preprocess.filter), {"gaussian", "median", "average", "unsharp", "none"},
                         "noise filter before the edge stage"),
      number("filter_sigma", FIELD(preprocess.filter_sigma), 0.0003, 0.1, "rad",
             "Gaussian sigma as a view angle, sigma_px = filter_sigma * fy (gaussian; also the blur of unsharp)"),
      number("filter_kernel", FIELD(preprocess.filter_kernel), 1, 31, "px",
             "odd aperture of median and average filters"),
      number("unsharp_amount", FIELD(preprocess.unsharp_amount), 0.0, 5.0, "", "gain of the unsharp mask"),
      number("encoding_gamma", FIELD(preprocess.encoding_gamma), 0.1, 1.0, "",
             "the camera's encoding exponent, pixel = radiance^encoding_gamma (sRGB webcams: about 0.45; 1 = "
             "linear); the bore's front rim is placed in linear light"),
      choice<BinarizeType>("binarize", FIELD(preprocess.binarize), {"fixed", "otsu", "none"},
                           "binarization before the Hough stage (thesis: fixed)"),
      number("binarize_threshold", FIELD(preprocess.binarize_threshold), 0.0, 1.0, "fraction of full scale",
             "fixed binarization level (thesis: 0.35)"),
      choice<MorphologyType>("morphology", FIELD(preprocess.morphology), {"open", "dilate", "erode", "none"},
                             "morphology on the binary image (thesis: open)"),
      number("morphology_radius", FIELD(preprocess.morphology_radius), 0, 15, "px",
             "radius of the disk structuring element"),
      number("min_component_area", FIELD(preprocess.min_component_area), 0, 100000, "px",
             "area opening: drop binary components smaller than this (0 = off)"),
      // Hough (thesis §3.3.4, Rule 1)
      number("edge_threshold", FIELD(hough.edge_threshold), 0.0, 1.0, "fraction of full scale",
             "minimum Sobel gradient magnitude of an edge pixel (along a predicted rim, where moving edges "
             "search a few px only: half of it)"),
      number("hole_edge_threshold", FIELD(hough.hole_edge_threshold), 0.0, 1.0, "fraction of full scale",
             "the same for the hole search, which only looks where a concentric hole can be"),
      number("sensitivity", FIELD(hough.sensitivity), 0.0, 0.99, "",
             "a flange needs (1 - sensitivity) of its visible rim supported (thesis: 0.89)"),
      number("hole_sensitivity", FIELD(hough.hole_sensitivity), 0.0, 0.99, "",
             "a hole needs (1 - hole_sensitivity) of its visible rim supported (thesis: 0.89)"),
      choice<Polarity>("flange_polarity", FIELD(hough.flange_polarity), polarity,
                       "flange disc darker or brighter than its surroundings"),
      choice<FlangeRetry>("flange_retry", FIELD(hough.flange_retry), {"none", "any_polarity"},
                          "when the flange_polarity search finds no spool with a hole rim, or one farther from the "
                          "reference than its flange radius: none, or any_polarity = search again with either "
                          "polarity (glossy faces under a lamp) and take its spool if nearer"),
      choice<Polarity>("hole_polarity", FIELD(hough.hole_polarity), polarity,
                       "hole disc darker or brighter than the flange face"),
      number("flange_radius_min", FIELD(hough.flange_radius_min), 0.0, 5000.0, "px",
             "smallest flange radius (0 = from distance_max and the focal length)"),
      number("flange_radius_max", FIELD(hough.flange_radius_max), 0.0, 5000.0, "px",
             "largest flange radius (0 = from distance_min and the focal length)"),
      number("hole_radius_min", FIELD(hough.hole_radius_min), 0.0, 1000.0, "px",
             "smallest hole radius (0 = from distance_max and the focal length)"),
      number("hole_radius_max", FIELD(hough.hole_radius_max), 0.0, 1000.0, "px",
             "largest hole radius (0 = from distance_min and the focal length)"),
      number("min_visible_fraction", FIELD(hough.min_visible_fraction), 0.05, 1.0, "",
             "ignore circles with less of their rim inside the image"),
      number("max_candidates", FIELD(hough.max_candidates), 1, 64, "", "flange candidates examined per frame"),
      number("edge_budget", FIELD(hough.edge_budget), 0.5, 1000.0, "per px of width + height",
             "most edges kept per frame (the strongest), which bounds the time of a cluttered frame; twice it "
             "in the second search of a frame that gave no spool"),
      // Concentric matcher (thesis Eq. 3.1, Rule 2)
      choice<MatchMode>("mode", FIELD(matcher.mode), {"mcht", "cht"},
                        "mcht: hole must be concentric with the flange; cht: no constraint"),
      choice<SpoolEvidence>("spool_evidence", FIELD(matcher.spool_evidence), {"hole", "bore", "flange"},
                            "mcht: hole = a spool needs a concentric hole rim; bore = that, or a strong flange whose "
                            "centre shows the bore as a darker or brighter disc; flange = the flange alone (thesis)"),
      number("flange_only_score", FIELD(matcher.flange_only_score), 0.0, 1.0, "",
             "spool_evidence bore: least rim score of a flange taken without a hole rim"),
      number("bore_contrast", FIELD(matcher.bore_contrast), 0.0, 1.0, "fraction of full scale",
             "spool_evidence bore: least difference between the bore disc and the face around it"),
      number("weak_hole_score", FIELD(matcher.weak_hole_score), 0.0, 1.0, "",
             "a hole rim scoring below this counts only where its disc also differs from the face by "
             "bore_contrast, and from 6 px of radius up only where it is darker (0 = every hole rim counts)"),
      number("cut_flange_hole_score", FIELD(matcher.cut_flange_hole_score), 0.0, 1.0, "",
             "the same on a flange with under 70% of its rim in the frame, often a neighbour's back flange "
             "centred on its face (0 = as weak_hole_score)"),
      number("concentric_tolerance", FIELD(matcher.concentric_tolerance), 0.0, 0.1, "rad",
             "hole centre within this view angle of the flange centre on each axis (thesis: 2 px at f = 200 px)"),
      number("hole_ratio_tolerance", FIELD(matcher.hole_ratio_tolerance), 0.0, 10.0, "",
             "relative deviation allowed from the hole/flange diameter ratio"),
      number("max_view_angle", FIELD(matcher.max_view_angle), 0.0, 1.2, "rad",
             "widest angle off the spool axis the flange is seen at, sideways; widens the window by r^2/f*tan"),
      number("max_view_pitch", FIELD(matcher.max_view_pitch), 0.0, 1.2, "rad",
             "the same up or down (camera pitch and height over the hole)"),
      // Geometry (thesis §3.4)
      number("flange_diameter", FIELD(geometry.flange_diameter), 0.01, 5.0, "m", "spool flange diameter"),
      number("hole_diameter", FIELD(geometry.hole_diameter), 0.001, 1.0, "m", "centre hole (bore) diameter"),
      number("axis_height_tolerance", FIELD(geometry.axis_height_tolerance), 0.01, 10.0, "m",
             "a spool's axis (hole centre) at most this far above or below the puller axis; the robot "
             "takes spools from the shelf level it stands at (10 = off)"),
      number("hub_length", FIELD(geometry.hub_length), 0.0, 5.0, "m",
             "front to back flange face; places the hole when an oblique fit follows both flanges"),
      number("bore_length_max", FIELD(geometry.bore_length_max), 0.0, 5.0, "m",
             "longest bore (about 20 cm, varies between spools): aligned checks the puller's miss at the "
             "bore's front and this far along the axis (0 = the front alone)"),
      number("puller_diameter", FIELD(geometry.puller_diameter), 0.0, 1.0, "m", "puller peg diameter"),
      number("distance_min", FIELD(geometry.distance_min), 0.05, 20.0, "m",
             "nearest working distance (sets the largest radii)"),
      number("distance_max", FIELD(geometry.distance_max), 0.05, 20.0, "m",
             "farthest working distance (sets the smallest radii)"),
      number("fallback_focal_length", FIELD(geometry.fallback_focal_length), 1.0, 10000.0, "px at 120 rows",
             "focal length without camera info, scaled with image height"),
      choice<YawMode>("yaw_mode", FIELD(geometry.yaw_mode), {"pinhole", "linear_fov"},
                      "pinhole: atan(du / fx); linear_fov: thesis Eq. 3.4/3.5"),
      number("field_of_view", FIELD(geometry.field_of_view), 0.01, 3.1, "rad",
             "diagonal field of view for linear_fov yaw (C270: 60 deg)"),
      choice<ReferenceMode>("reference_mode", FIELD(geometry.reference_mode), {"puller", "fixed"},
                            "puller: projected puller axis; fixed: reference_x/y"),
      number("reference_x", FIELD(geometry.reference_x), -1e4, 1e4, "px",
             "fixed reference column (thesis: 80 at 160x120)"),
      number("reference_y", FIELD(geometry.reference_y), -1e4, 1e4, "px",
             "fixed reference row (thesis: 50 at 160x120)"),
      number("puller_offset_x", FIELD(geometry.puller_offset_x), -2.0, 2.0, "m",
             "puller axis from the camera along camera x (right)"),
      number("puller_offset_y", FIELD(geometry.puller_offset_y), -2.0, 2.0, "m",
             "puller axis from the camera along camera y (down)"),
      number("overlap_tolerance", FIELD(geometry.overlap_tolerance), 0.0, 0.1, "rad",
             "Rule 3: flange and hole centres within this view angle of the reference (thesis: 2 px at f = 200 px)"),
      number("aligned_max_yaw", FIELD(geometry.aligned_max_yaw), 0.0, 0.5, "rad",
             "largest |yaw| reported as aligned (0.25 deg = 0.00436)"),
      number("aligned_distance_min", FIELD(geometry.aligned_distance_min), 0.0, 20.0, "m",
             "insertion window, near end"),
      number("aligned_distance_max", FIELD(geometry.aligned_distance_max), 0.0, 20.0, "m", "insertion window, far end"),
      number("aligned_margin", FIELD(geometry.aligned_margin), 0.0, 0.01, "m",
             "aligned needs the puller's miss at both bore ends within t_f minus this (measurement error)"),
      number("aligned_max_pixel_angle", FIELD(geometry.aligned_max_pixel_angle), 0.0, 1.0, "rad",
             "aligned only where one pixel subtends at most this (1 / fy; 640x480: 0.00125): a coarser image "
             "measures the spool axis too loosely to clear t_f over the bore (1 = off)"),
      // Tracking over the approach (SpoolTracker; the node's ~track, spool_detect --track)
      number("track_acceleration", FIELD(tracker.acceleration), 0.01, 50.0, "m/s^2",
             "process noise: white-noise acceleration of the bore's front centre relative to the camera"),
      number("track_axis_drift", FIELD(tracker.axis_drift), 0.0, 1.0, "rad/sqrt(s)",
             "process noise: random walk of the spool axis seen from the camera"),
      number("track_odometry_noise", FIELD(tracker.odometry_noise), 0.0, 1.0, "",
             "relative 1 sigma of the camera motion from odometry (of the distance driven and the angle turned "
             "between frames), where the node has odometry (~odom_frame) or spool_sim drives"),
      number("track_level_pitch_sigma", FIELD(tracker.level_pitch_sigma), 0.0, 0.2, "rad",
             "> 0: the spool axis's pitch is taken as level (track_level_pitch) with this 1 sigma instead of "
             "the rim's measurement, biased 0.1-0.5 deg (spools lying on a level board, a level camera: the "
             "job), and the detector fits an oblique bore's ellipse with that pitch; 0 = measured from the rim (a "
             "shelf that is not level)"),
      number("track_level_pitch", FIELD(tracker.level_pitch), -0.5, 0.5, "",
             "slope y/z of a level spool's axis in the camera optical frame (tan of the camera's downward tilt)"),
      number("track_gate", FIELD(tracker.gate), 1.0, 100.0, "",
             "Mahalanobis distance from the prediction beyond which a detection is refused, not fused"),
      number("track_max_coast", FIELD(tracker.max_coast), 0, 1000, "frames",
             "frames without a fused detection before the track is lost"),
      number("track_confirm_frames", FIELD(tracker.confirm_frames), 1, 100, "frames",
             "frames in a row the filtered state must clear the bore before aligned"),
      number("track_aligned_sigma", FIELD(tracker.aligned_sigma), 0.0, 10.0, "",
             "aligned needs each puller miss plus this many standard deviations within t_f - aligned_margin"),
      number("track_aligned_max_pixel_angle", FIELD(tracker.aligned_max_pixel_angle), 0.0, 1.0, "rad",
             "tracked aligned only where one pixel subtends at most this (1 / fy; 640x480: 0.00125, 320x240: "
             "0.0025, 160x120: 0.005): from 320x240 up the filter's sigma decides (docs/closed_loop.md: 196 of 200 "
             "inserted at 320x240, no collision); 0.0015 keeps it to 640x480 and up, as `aligned_max_pixel_angle` "
             "does per frame"),
      number("track_noise_scale", FIELD(tracker.noise_scale), 0.1, 10.0, "",
             "multiplies the measured error model's sigmas (docs/error_model.md)"),
      number("track_full_search_interval", FIELD(tracker.full_search_interval), 1, 1000, "frames",
             "while tracking the flange is searched where the track predicts it, the whole frame every this many "
             "frames (1 = always)"),
      choice<TrackMeasurement>("track_measurement", FIELD(tracker.measurement), {"moving_edges", "window"},
                               "how the tracked flange is measured between whole-frame searches: moving_edges = "
                               "along the rim the track predicts (its normals only) and the bore at its known size "
                               "where the track puts it, or window = a Hough search of the predicted window"),
  };
}
#undef FIELD

std::string typeName(ParamType t)
{
  switch (t)
  {
    case ParamType::kInt:
      return "an integer";
    case ParamType::kDouble:
      return "a number";
    case ParamType::kChoice:
      return "a word";
  }
  return "?";
}

[[noreturn]] void fail(const ParamSpec& spec, const std::string& why)
{
  throw ParamError(spec.key, why + "; allowed: " + spec.allowed());
}

// The value as the key's type (an int for an integral double, a double for an int), or throws.
ParamValue checkedValue(const ParamSpec& spec, const ParamValue& value)
{
  if (spec.type == ParamType::kChoice)
  {
    const auto* word = std::get_if<std::string>(&value);
    if (!word)
      fail(spec, "expected a word, got " + formatParamValue(value));
    for (const auto& c : spec.choices)
      if (c == *word)
        return value;
    fail(spec, "'" + *word + "' is not a choice");
  }

  double number = 0.0;
  if (const auto* i = std::get_if<int>(&value))
    number = *i;
  else if (const auto* d = std::get_if<double>(&value))
    number = *d;
  else
    fail(spec, "expected " + typeName(spec.type) + ", got " + formatParamValue(value));

  if (!std::isfinite(number) || number < spec.min_value || number > spec.max_value)
    fail(spec, formatNumber(number) + " is out of range");
  if (spec.type == ParamType::kInt)
  {
    if (number != std::floor(number))
      fail(spec, formatNumber(number) + " is not an integer");
    return static_cast<int>(number);
  }
  return number;
}

}  // namespace

std::string ParamSpec::allowed() const
{
  if (type == ParamType::kChoice)
  {
    std::string s = "one of ";
    for (size_t i = 0; i < choices.size(); ++i)
      s += (i ? "|" : "") + choices[i];
    return s;
  }
  return typeName(type) + " in [" + formatNumber(min_value) + ", " + formatNumber(max_value) + "]" +
         (unit.empty() ? "" : " " + unit);
}

const std::vector<ParamSpec>& paramSpecs()
{
  static const std::vector<ParamSpec> specs = buildSpecs();
  return specs;
}

const ParamSpec* findParamSpec(const std::string& key)
{
  for (const auto& spec : paramSpecs())
    if (spec.key == key)
      return &spec;
  return nullptr;
}

void setParam(DetectorParams& params, const std::string& key, const ParamValue& value)
{
  const ParamSpec* spec = findParamSpec(key);
  if (!spec)
    throw ParamError(key, "unknown parameter");
  spec->set(params, checkedValue(*spec, value));
}

void validateParams(const DetectorParams& p)
{
  // A struct filled in code is held to the same table as a YAML file.
  for (const auto& spec : paramSpecs())
    checkedValue(spec, spec.get(p));

  auto order = [](const char* lo_key, double lo, const char* hi_key, double hi)
  {
    if (lo > 0.0 && hi > 0.0 && lo >= hi)
      throw ParamError(hi_key, "must be greater than " + std::string(lo_key) + " (" + formatNumber(lo) + ")");
  };
  const auto& h = p.hough;
  order("flange_radius_min", h.flange_radius_min, "flange_radius_max", h.flange_radius_max);
  order("hole_radius_min", h.hole_radius_min, "hole_radius_max", h.hole_radius_max);
  const auto& g = p.geometry;
  order("distance_min", g.distance_min, "distance_max", g.distance_max);
  order("aligned_distance_min", g.aligned_distance_min, "aligned_distance_max", g.aligned_distance_max);
  if (g.hole_diameter >= g.flange_diameter)
    throw ParamError("hole_diameter",
                     "must be smaller than flange_diameter (" + formatNumber(g.flange_diameter) + " m)");
  if (g.puller_diameter > g.hole_diameter)
    throw ParamError("puller_diameter", "must not exceed hole_diameter (" + formatNumber(g.hole_diameter) + " m)");
  const int k = p.preprocess.filter_kernel;
  if (k % 2 == 0)
    throw ParamError("filter_kernel", std::to_string(k) + " is even; allowed: odd integers in [1, 31]");
}

std::string formatParamValue(const ParamValue& value)
{
  if (const auto* b = std::get_if<bool>(&value))
    return *b ? "true" : "false";
  if (const auto* i = std::get_if<int>(&value))
    return std::to_string(*i);
  if (const auto* d = std::get_if<double>(&value))
  {
    std::ostringstream os;
    os.precision(10);
    os << *d;
    return os.str();
  }
  return std::get<std::string>(value);
}

}  // namespace spool_vision
