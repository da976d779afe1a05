// Synthetic shelf-of-spools renderer with exact ground truth (ROS-free: OpenCV + Eigen only).
//
// World frame: x right along the shelf, y up (floor at y = 0), z from the camera side into the
// shelf. The target spool's axis is the line x = 0, y = kHoleHeight; its front flange face lies
// in the plane z = 0 and the spool extends to z = bore_length, the back wall stands behind it.
// Every surface is either perpendicular or parallel to z, which keeps ray casting cheap.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
#include "spool_vision/render/wall_print.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// The thesis' four lamp switch conditions (§3.2, Fig. 3.5).
enum class LampCondition
{
  kS1S2,  ///< 108-126 lx
  kS1S3,  ///< 98-121 lx
  kS2S3,  ///< 140-170 lx
  kAll    ///< 179-205 lx
};

/// What stands in the target slot.
enum class SceneKind
{
  kSpool,      ///< a copper-wire spool (positive)
  kEmptySlot,  ///< nothing: shelf board and back wall
  kPlate,      ///< a plate standing on its edge, facing the camera
  kTapeRoll,   ///< an adhesive tape roll standing on its edge (has a see-through core)
  kCan         ///< a tin can lying with its lid towards the camera
};

const char* toString(LampCondition lamps);
const char* toString(SceneKind kind);
/// Illuminance range (lx) the thesis measured for a condition.
void lampRange(LampCondition lamps, double& min_lux, double& max_lux);

/// Where the camera is. Position and orientation are relative to the target slot's hole axis.
struct CameraPose
{
  double distance = 0.8;  ///< m, optical centre to the flange face centre (Euclidean: the range)
  double lateral = 0.0;   ///< m, camera x relative to the hole axis (positive = camera right)
  /// m, camera above the hole axis; by default the puller's offset below the camera
  /// (GeometryParams::puller_offset_y), which puts the puller at the axis's height
  double height = GeometryParams{}.puller_offset_y;
  double yaw = 0.0;    ///< rad, rotation about the vertical axis, positive turns right
  double pitch = 0.0;  ///< rad, positive tilts the optical axis down
};

/// One spool standing beside the target slot.
struct NeighbourSpool
{
  int side = 1;               ///< -1 left, +1 right
  double gap = 0.03;          ///< m, between its flange rim and the next flange rim inwards
  double depth_offset = 0.0;  ///< m, its flange face z (positive = set back)
};

/// A second row of spools behind the first (a deep shelf), of the target's make, their axes
/// along z at the hole height, seen through the gaps between the front row's flanges.
struct BackRow
{
  double z = 0.0;           ///< m, the z of its front flange faces; 0 = no back row, else > bore_length
  double offset = 0.0;      ///< m, x of one of its spools' axes (the others every flange_diameter + gap)
  double gap = 0.02;        ///< m, between neighbouring back-row flange rims
  double half_width = 1.0;  ///< m, its spools stand with their axes within this of x = 0
};

/// A disc or ring hung on the back wall (clutter a detector must not take for a spool).
struct WallMark
{
  double x = 0.0;                   ///< m, centre
  double y = 1.0;                   ///< m, centre height above the floor
  double radius = 0.05;             ///< m
  double inner_radius = 0.0;        ///< m, 0 = a full disc
  cv::Vec3d colour{0.2, 0.2, 0.2};  ///< BGR reflectance
};

/// A box standing on a shelf board (clutter). It stands at or behind the flange face plane, so
/// it can never hide the target's face centre.
struct ShelfBox
{
  double x = 0.4;                   ///< m, centre
  double z = 0.0;                   ///< m, front face, >= 0
  double width = 0.1;               ///< m
  double height = 0.1;              ///< m
  double depth = 0.1;               ///< m
  bool upper = false;               ///< stands on the upper board instead of the lower one
  cv::Vec3d colour{0.3, 0.5, 0.6};  ///< BGR reflectance
};

/// Everything about a scene except the camera pose. Deterministic: the same parameters
/// (including seed) render the same image.
struct SceneParams
{
  SceneKind kind = SceneKind::kSpool;
  LampCondition lamps = LampCondition::kAll;
  double illuminance = 0.0;  ///< lx; 0 = the middle of the condition's range
  double exposure = 1.0;     ///< camera gain multiplier

  // Spool (thesis spool: 35 cm flange, 3.6 cm bore through a ~20 cm hub), by default the one the
  // detector's GeometryParams describe.
  double flange_diameter = GeometryParams{}.flange_diameter;  ///< m
  double hole_diameter = GeometryParams{}.hole_diameter;      ///< m
  double bore_length = GeometryParams{}.hub_length;           ///< m, front flange face to back flange face
  double flange_thickness = 0.012;                            ///< m
  double winding_diameter = 0.28;                             ///< m, outer diameter of the copper winding
  double flange_reflectance = 0.06;                           ///< black plastic
  double bore_reflectance = 0.2;                              ///< bore wall at mid depth (darker towards the front)
  bool ribs = true;                                           ///< concentric moulded ribs on the flange face
  /// rad, slope of the ribs' flanks: > 0 shades each rib as a raised ring whose flanks catch or
  /// miss the lamps (bright and dark thin circles); 0 = a faintly brighter flat crest
  double rib_slope = 0.0;
  /// Glossy face: peak reflectance of a tube lamp's mirror image on the flange faces (a broad
  /// bright streak where the camera sees the lamp reflected); 0 = matte
  double gloss = 0.0;
  cv::Vec3d gloss_lamp{0.0, 1.4, -1.0};  ///< m, a point on the tube lamp (world frame)
  double gloss_lamp_angle = 0.0;         ///< rad, direction of the tube in the x-y plane (0 = along x)
  double gloss_spread = 0.1;             ///< m, blur of the lamp's mirror image (face roughness)
  /// m, light entering either bore opening fades along the bore wall over this length, so deep
  /// inside the bore is near black; 0 = a wall lit from the back, darkening towards the front
  double bore_falloff = 0.0;
  bool label = false;          ///< paper label on the flange face
  double label_angle = 0.8;    ///< rad, direction of the label centre from the axis
  double label_radius = 0.11;  ///< m, label centre from the axis

  std::vector<NeighbourSpool> neighbours;
  BackRow back_row;  ///< behind the front row (which holds the slot and its neighbours)

  // Negative objects (kPlate, kTapeRoll, kCan): size and position in the slot.
  double object_radius = 0.11;             ///< m
  double object_offset_x = 0.0;            ///< m, from the slot centre
  double object_depth = 0.02;              ///< m, z of its front face
  cv::Vec3d object_colour{0.8, 0.8, 0.8};  ///< BGR reflectance

  // Shelf.
  double wall_gap = 0.10;                   ///< m, back flange face (of the back row, if any) to back wall
  double board_front = -0.02;               ///< m, z of the shelf boards' front edge
  double board_thickness = 0.025;           ///< m
  double top_board_clearance = 0.08;        ///< m, flange top to the upper board
  cv::Vec3d wall_colour{0.70, 0.74, 0.76};  ///< BGR reflectance
  std::vector<WallMark> wall_marks;         ///< clutter on the back wall
  /// Photograph-like prints on the back wall (later ones in front), drawn where no wall mark is
  /// and not within 12 cm of the target's axis (its bore's see-through shows the plain wall)
  std::vector<WallPrint> wall_prints;
  std::vector<ShelfBox> boxes;  ///< clutter on the boards beside the slot

  /// m, how far ahead of the camera the puller rod's tip reaches along the optical axis; the rod
  /// (kPullerDiameter, kPullerOffsetY below the camera) enters from the image bottom; 0 = out of view
  double puller_rod_length = 0.0;

  // Camera imperfections. Lengths "px @480" are pixels at 480 image rows, scaled with the image
  // height (a webcam's smaller modes bin the same optics).
  double blur_sigma = 0.5;   ///< px, optical blur (0 = none)
  double noise_sigma = 2.0;  ///< DN at mid grey (8 bit) and unit gain, grows with signal and gain
  int jpeg_quality = 0;      ///< 1-100, 0 = no JPEG round trip
  double vignetting = 0.1;   ///< brightness loss in the image corners
  /// Centre-weighted auto exposure: the gain (on top of `exposure`) that brings the
  /// centre-weighted mean of the output to this fraction of full scale; 0 = fixed gain
  double auto_exposure_target = 0.0;
  double auto_exposure_max_gain = 8.0;     ///< the sensor's gain limit
  double gamma = 1.0;                      ///< output = linear^gamma (webcams: about 0.45); 1 = linear
  cv::Vec3d white_balance{1.0, 1.0, 1.0};  ///< BGR channel gains (white-balance error)
  double defocus_radius = 0.0;             ///< px @480, radius of the defocus disc (0 = sharp)
  double motion_blur = 0.0;                ///< px @480, smear length during the exposure (0 = none)
  /// true: the smear runs radially from the principal point (driving forward), `motion_blur` at
  /// the image corner; false: a straight smear along motion_blur_angle
  bool motion_blur_radial = false;
  double motion_blur_angle = 0.0;  ///< rad, from the image u axis
  std::uint64_t seed = 1;          ///< texture and noise
};

/// A 3D circle (rim) as it appears in the image. With lens distortion the positions (x, y,
/// centre_x, centre_y, visible_fraction) are those of the distorted image the camera delivers;
/// the sizes and the angle are those of the undistorted projection (the ellipse the pinhole
/// camera K would see, i.e. the rectified image), which is what the geometry (Eq. 3.2) needs.
struct ProjectedCircle
{
  double x = 0.0;  ///< px, centre of the projected ellipse (what a circle fit finds), distorted
  double y = 0.0;
  double centre_x = 0.0;  ///< px, projection of the circle's 3D centre, distorted
  double centre_y = 0.0;
  double r = 0.0;                 ///< px, mean of the semi-axes (undistorted projection)
  double semi_major = 0.0;        ///< px (undistorted projection)
  double semi_minor = 0.0;        ///< px (undistorted projection)
  double angle = 0.0;             ///< rad, major axis from the image u axis (undistorted projection)
  double r_vertical = 0.0;        ///< px, half the vertical extent (undistorted projection)
  double visible_fraction = 0.0;  ///< fraction of the rim inside the (distorted) image
};

/// A spool beside the target slot, measured the way the target is.
struct NeighbourTruth
{
  ProjectedCircle flange;  ///< its front flange rim
  double distance = 0.0;   ///< m, depth: z of its flange face centre in the camera optical frame
  double yaw = 0.0;        ///< rad, bearing of its flange centre from the puller column
  /// in the back row: behind the front row, so never the target (the puller reaches the front row)
  bool back_row = false;
  /// rad, between its axis and the line of sight to its flange face centre (0 = seen face-on)
  double view_angle = 0.0;
};

/// Exact ground truth of one rendered frame. Undefined numbers are NaN.
struct GroundTruth
{
  SceneKind kind = SceneKind::kSpool;
  LampCondition lamps = LampCondition::kAll;
  double illuminance = 0.0;  ///< lx
  CameraPose pose;
  CameraIntrinsics camera;

  std::optional<ProjectedCircle> flange;  ///< front flange rim; only for a spool
  std::optional<ProjectedCircle> hole;    ///< front opening of the bore; only for a spool
  /// m, the bore's front centre (= the flange face centre, where the spool axis leaves the front
  /// face) in the camera optical frame (REP 103: x right, y down, z forward)
  cv::Point3d position{SpoolDetection::kNaN, SpoolDetection::kNaN, SpoolDetection::kNaN};
  double distance = SpoolDetection::kNaN;  ///< m, depth: position.z (DESIGN.md §5, thesis Eq. 3.2)
  double range = SpoolDetection::kNaN;     ///< m, |position|: optical centre to the bore's front centre
  /// rad, atan((u_flange - u_ref) / fx) in the undistorted image, with u_flange the projected 3D
  /// flange centre and u_ref the projection of the puller axis point at the flange depth, i.e.
  /// atan(position.x / position.z) (puller at x = 0); positive = spool appears right.
  double yaw = SpoolDetection::kNaN;
  /// m, position.x minus the puller axis' x (0): positive = the bore is right of the puller
  double lateral_offset = SpoolDetection::kNaN;
  cv::Point2d reference{SpoolDetection::kNaN, SpoolDetection::kNaN};  ///< px, puller axis at the flange depth
  bool flange_half_visible = false;  ///< at least half of the flange rim inside the image
  /// The whole front opening inside the image and not hidden by the puller rod. A hole in view
  /// but dark (the detector must still find its front rim) is hole_in_view && !bore_visible.
  bool hole_in_view = false;
  bool hole_occluded = false;      ///< the puller rod hides part of the front opening
  bool bore_visible = false;       ///< the lit wall shows through the bore
  double hole_lit_fraction = 0.0;  ///< lit part of the front opening's area, 0..1
  /// px, centroid of the see-through lens (the front opening where the back opening shows
  /// through; above the rim's centre when the camera is above the axis); NaN when none
  cv::Point2d hole_lens{SpoolDetection::kNaN, SpoolDetection::kNaN};
  /// m, the puller axis to the bore axis in the plane of the bore's front face
  double puller_miss = SpoolDetection::kNaN;
  /// Unit vector along the spool axis from the front face into the spool, camera optical frame
  cv::Vec3d axis{SpoolDetection::kNaN, SpoolDetection::kNaN, SpoolDetection::kNaN};
  double axis_angle = SpoolDetection::kNaN;  ///< rad, between the spool axis and the puller axis (optical z)
  double axis_yaw = SpoolDetection::kNaN;    ///< rad, atan2(axis.x, axis.z): positive = the axis heads right
  /// rad, between the spool axis and the line of sight to the bore's front centre (0 = seen
  /// face-on); the flange's ellipse is about cos(view_angle) as wide across the axis' turn as along it
  double view_angle = SpoolDetection::kNaN;
  /// The puller pushed straight in would not touch the bore wall: its axis (camera frame: through
  /// (0, kPullerOffsetY, 0) along +z) lies within t_f = (hole_diameter - kPullerDiameter) / 2 of
  /// the bore axis in the plane of the bore's front face and in that of its back end (bore_length
  /// along the axis); between them the miss is never larger.
  bool puller_clears = false;
  /// m, t_f minus the larger of the two misses above: how far the puller clears the bore wall at
  /// its tighter end (negative where it would touch)
  double puller_clearance = SpoolDetection::kNaN;
  /// Ready to insert: puller_clears and kAlignedDistanceMin <= distance <= kAlignedDistanceMax.
  bool aligned = false;
  std::vector<NeighbourTruth> neighbours;  ///< spools beside the slot (a detector may see them)
  bool spool_centre_in_view = false;       ///< any spool's flange centre (target or neighbour) in view
};

struct RenderedFrame
{
  cv::Mat image;  ///< CV_8UC3, BGR
  GroundTruth truth;
};

/// Ray casts the scene: one ray per pixel centre, 4x4 rays on pixels where surfaces meet. With a
/// lens distortion in the camera (plumb_bob or rational_polynomial) each ray goes along the
/// undistorted direction of its pixel, so the image is distorted as the lens would distort it,
/// without resampling.
class SpoolRenderer
{
public:
  /// Throws std::invalid_argument on invalid intrinsics.
  explicit SpoolRenderer(const CameraIntrinsics& camera);

  const CameraIntrinsics& camera() const
  {
    return camera_;
  }

  /// Throws std::invalid_argument when the pose is impossible (distance below the offsets,
  /// the target's front flange not entirely in front of the camera).
  RenderedFrame render(const SceneParams& scene, const CameraPose& pose) const;

  /// The ground truth alone (cheap).
  GroundTruth groundTruth(const SceneParams& scene, const CameraPose& pose) const;

  /// Hole height above the floor (m). The puller (its offset in the camera frame and its diameter,
  /// m) and the insertion window (depth, m) are the detector's defaults (GeometryParams).
  static constexpr double kHoleHeight = 1.0;
  static constexpr double kPullerOffsetY = GeometryParams{}.puller_offset_y;
  static constexpr double kPullerDiameter = GeometryParams{}.puller_diameter;
  static constexpr double kAlignedDistanceMin = GeometryParams{}.aligned_distance_min;
  static constexpr double kAlignedDistanceMax = GeometryParams{}.aligned_distance_max;

private:
  CameraIntrinsics camera_;
};

/// Random but plausible scene parameters of the given kind (lamps, neighbours, label, ribs,
/// imperfections, object size, a webcam's gamma of 0.4-0.5). Deterministic in `seed`.
SceneParams randomScene(SceneKind kind, std::uint64_t seed);

/// randomScene's shelf with real-webcam effects and finishes drawn on top: auto exposure with
/// gamma, gain noise, white-balance error, vignetting, defocus, motion blur, MJPEG, glossy and
/// ribbed faces, a dark bore interior, clutter and the puller rod (the hard set). Deterministic.
SceneParams randomHardScene(SceneKind kind, std::uint64_t seed);

/// Packs `scene`'s shelf as real shelves are (issue 28): 1-3 neighbours each side, their flange rims
/// touching (half the scenes) or 2-15 mm apart, and on scenes with a spool in the slot, seven in
/// ten, a back row 0-6 cm behind the front row's back flanges, set off by a random fraction of
/// its pitch, its rims 0-5 cm apart. Draws from its own stream of `seed`: what it leaves alone
/// keeps its values. Deterministic.
void packShelf(std::uint64_t seed, SceneParams& scene);

/// `truth` as a JSON object, keys in a fixed order; NaN and missing circles are null.
nlohmann::ordered_json groundTruthJson(const GroundTruth& truth);

}  // namespace spool_vision
