#include "spool_vision/render/spool_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace spool_vision
{
namespace
{
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Json = nlohmann::ordered_json;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-9;
constexpr int kSuperSamples = 4;  // per axis, on pixels where surfaces meet
constexpr int kRimSamples = 720;
// m: prints leave the wall plain this far about the target's axis, so that what shows through its
// bore is the wall the truth's lit bore assumes (the see-through wanders this far at 40 deg).
constexpr double kPlainWallRadius = 0.12;
// Moulded ribs on the flange face: radii of their crests (m), crest half width and flank width.
constexpr std::array<double, 4> kRibRadii = {0.05, 0.08, 0.115, 0.15};
constexpr double kRibHalfWidth = 0.002;
constexpr double kRibFlank = 0.002;

enum class Material : std::uint8_t
{
  kWall,
  kBoard,
  kFlange,
  kCopper,
  kBore,
  kObject,
  kObjectRim,
  kCardboard,
  kMetal,
  kClutter,  // owner: index into the clutter colours
  kRod       // the puller rod
};

// A disc or annulus in the plane z = const, facing the camera (-z).
struct Disc
{
  double cx, cy, z, r_in2, r_out2;
  Material material;
  int owner;      // index into SceneGeometry::spools, -1 for other objects
  bool textured;  // front flange face: ribs and label
};

// A cylinder surface around an axis parallel to z; `inward` surfaces are seen from inside.
struct Tube
{
  double cx, cy, z0, z1, r;
  bool inward;
  Material material;
};

struct Group
{
  Vec3 centre = Vec3::Zero();
  double radius2 = 0.0;  // bounding sphere
  std::vector<Disc> discs;
  std::vector<Tube> tubes;
  int first_id = 0;
};

struct SpoolInfo
{
  double cx, cy;
  double label_angle;
};

struct Hit
{
  double t = kInf;
  int id = -1;
  Material material = Material::kWall;
  Vec3 normal = Vec3::Zero();
  int owner = -1;
  bool textured = false;
  double z_front = 0.0;  // tubes: where the surface starts and ends, for the bore's shading
  double z_back = 0.0;
};

// An axis-aligned box (shelf board or clutter box).
struct Box
{
  std::array<Vec3, 2> bounds;
  Material material;
  int owner;  // clutter colour index, -1 for boards
};

// Camera placement: centre in world and the camera-to-world rotation (columns: x right,
// y down, z forward).
struct CameraFrame
{
  Vec3 centre;
  Mat3 rotation;
};

// Where a ray from the camera centre along `d` (camera frame) enters the puller rod's surface:
// the ray parameter, or infinity when it misses. The rod's axis runs parallel to the optical
// axis kPullerOffsetY below the camera, from the camera plane to `length` ahead.
double pullerRodHit(const Vec3& d, double length, Vec3* normal = nullptr)
{
  const double offset = SpoolRenderer::kPullerOffsetY;
  const double radius = 0.5 * SpoolRenderer::kPullerDiameter;
  const double a = d.x() * d.x() + d.y() * d.y();
  const double b = -d.y() * offset;
  const double disc = b * b - a * (offset * offset - radius * radius);
  if (length <= 0.0 || a < kEps || disc < 0.0)
    return kInf;
  const double t = (-b - std::sqrt(disc)) / a;
  const double z = t * d.z();
  if (t <= kEps || z < 0.0 || z > length)
    return kInf;
  if (normal)
    *normal = Vec3(t * d.x() / radius, (t * d.y() - offset) / radius, 0.0);
  return t;
}

// Lamps as seen from the shelf: S1 left, S2 centre, S3 right, all above and in front. The
// nominal shares solve the thesis' pairwise readings (S1+S2 117, S1+S3 110, S2+S3 155 lx).
const std::array<Vec3, 3>& lampDirections()
{
  static const std::array<Vec3, 3> dirs = {Vec3(-1.0, 1.3, -1.4).normalized(), Vec3(0.1, 1.4, -1.3).normalized(),
                                           Vec3(1.1, 1.2, -1.2).normalized()};
  return dirs;
}
constexpr std::array<double, 3> kLampShare = {36.0, 81.0, 74.0};

// The thesis' lamp switch conditions, in LampCondition order: name, measured illuminance range
// (lx) and which of S1, S2, S3 are on.
struct LampSpec
{
  const char* name;
  double min_lux;
  double max_lux;
  std::array<bool, 3> on;
};
constexpr std::array<LampSpec, 4> kLampSpecs = {{{"S1+S2", 108.0, 126.0, {true, true, false}},
                                                 {"S1+S3", 98.0, 121.0, {true, false, true}},
                                                 {"S2+S3", 140.0, 170.0, {false, true, true}},
                                                 {"S1+S2+S3", 179.0, 205.0, {true, true, true}}}};
static_assert(kLampSpecs.size() == static_cast<std::size_t>(LampCondition::kAll) + 1, "one row per condition");

const LampSpec& lampSpec(LampCondition lamps)
{
  return kLampSpecs[static_cast<std::size_t>(lamps)];
}

// The scene's illuminance (lx): as given, or the middle of its lamp condition's range.
double sceneIlluminance(const SceneParams& p)
{
  const LampSpec& spec = lampSpec(p.lamps);
  return p.illuminance > 0.0 ? p.illuminance : 0.5 * (spec.min_lux + spec.max_lux);
}

constexpr double kReferenceLux = 200.0;  // exposure that puts a 0.75 white wall near 190 DN
constexpr double kAmbientFraction = 0.35;
constexpr double kFrontCosine = 0.6;  // typical n.l of a face towards the camera
constexpr int kAmbientRays = 16;      // rays per back-row point towards the room (reachingLight())

// Front flange centres of the neighbour spools, packed outwards from the slot.
std::vector<Vec3> neighbourCentres(const SceneParams& p)
{
  std::vector<Vec3> centres;
  double left = 0.0;
  double right = 0.0;
  for (const NeighbourSpool& n : p.neighbours)
  {
    double& edge = n.side < 0 ? left : right;
    edge += p.flange_diameter + n.gap;
    centres.emplace_back(n.side < 0 ? -edge : edge, SpoolRenderer::kHoleHeight, n.depth_offset);
  }
  return centres;
}

// Front flange centres of the back row's spools: every pitch from its offset, within its half width.
std::vector<Vec3> backRowCentres(const SceneParams& p)
{
  std::vector<Vec3> centres;
  const BackRow& row = p.back_row;
  if (row.z <= 0.0)
    return centres;
  const double pitch = p.flange_diameter + row.gap;
  // Spool k (k = first, first + 1, ...) stands at offset + k pitch.
  const int first = static_cast<int>(std::ceil((-row.half_width - row.offset) / pitch));
  const int last = static_cast<int>(std::floor((row.half_width - row.offset) / pitch));
  for (int k = first; k <= last; ++k)
    centres.emplace_back(row.offset + k * pitch, SpoolRenderer::kHoleHeight, row.z);
  return centres;
}

Vec3 toVec(const cv::Vec3d& v)
{
  return Vec3(v[0], v[1], v[2]);
}

// What a scene holds, as primitives the ray caster intersects: the shelf boards and clutter
// boxes, then groups of discs and tubes (wall marks, the spools, the object), each primitive
// with its own id (0 is the wall; the puller rod takes next_id).
struct SceneGeometry
{
  double wall_z = 0.3;
  double lower_board_top = 0.0;
  double lower_board_bottom = 0.0;
  double upper_board_bottom = 0.0;
  double object_cx = 0.0;
  double object_cy = 0.0;
  std::vector<Box> boxes;  // the two shelf boards, then clutter boxes
  std::vector<Vec3> clutter_colours;
  std::vector<Group> groups;
  std::vector<SpoolInfo> spools;
  int next_id = 0;
  int back_row_id = -1;  // the first id of the back row's primitives (lit through the front row), -1: none
};

// --- the scene description ---------------------------------------------------------------

// Appends a group, its primitives numbered on from the last.
void addGroup(Group g, SceneGeometry& geometry)
{
  g.first_id = geometry.next_id;
  geometry.next_id += static_cast<int>(g.discs.size() + g.tubes.size());
  geometry.groups.push_back(std::move(g));
}

void addSpool(const SceneParams& p, double cx, double z0, double label_angle, SceneGeometry& geometry)
{
  const double cy = SpoolRenderer::kHoleHeight;
  const double big = 0.5 * p.flange_diameter;
  const double hole = 0.5 * p.hole_diameter;
  const double wind = 0.5 * p.winding_diameter;
  const double len = p.bore_length;
  const double th = p.flange_thickness;
  const int owner = static_cast<int>(geometry.spools.size());
  geometry.spools.push_back({cx, cy, label_angle});

  Group g;
  g.centre = Vec3(cx, cy, z0 + 0.5 * len);
  g.radius2 = big * big + 0.25 * len * len + 1e-4;
  g.discs.push_back({cx, cy, z0, hole * hole, big * big, Material::kFlange, owner, true});
  g.discs.push_back({cx, cy, z0 + len - th, wind * wind, big * big, Material::kFlange, owner, false});
  g.tubes.push_back({cx, cy, z0, z0 + th, big, false, Material::kFlange});
  g.tubes.push_back({cx, cy, z0 + th, z0 + len - th, wind, false, Material::kCopper});
  g.tubes.push_back({cx, cy, z0 + len - th, z0 + len, big, false, Material::kFlange});
  g.tubes.push_back({cx, cy, z0, z0 + len, hole, true, Material::kBore});
  addGroup(std::move(g), geometry);
}

void addObject(const SceneParams& p, SceneGeometry& geometry)
{
  const double r = p.object_radius;
  const double cx = p.object_offset_x;
  const double cy = geometry.lower_board_top + r;  // it stands on the board
  const double z0 = p.object_depth;
  geometry.object_cx = cx;
  geometry.object_cy = cy;
  Group g;
  switch (p.kind)
  {
    case SceneKind::kPlate:
    {
      const double th = 0.015;
      g.discs.push_back({cx, cy, z0, 0.0, std::pow(0.75 * r, 2), Material::kObject, -1, false});
      g.discs.push_back({cx, cy, z0, std::pow(0.75 * r, 2), r * r, Material::kObjectRim, -1, false});
      g.tubes.push_back({cx, cy, z0, z0 + th, r, false, Material::kObjectRim});
      g.centre = Vec3(cx, cy, z0);
      g.radius2 = r * r + th * th + 1e-4;
      break;
    }
    case SceneKind::kTapeRoll:
    {
      const double width = 0.03;
      const double inner = 0.038;  // 76 mm cardboard core
      const double core = inner + 0.004;
      g.discs.push_back({cx, cy, z0, core * core, r * r, Material::kObject, -1, false});
      g.discs.push_back({cx, cy, z0, inner * inner, core * core, Material::kCardboard, -1, false});
      g.tubes.push_back({cx, cy, z0, z0 + width, r, false, Material::kObject});
      g.tubes.push_back({cx, cy, z0, z0 + width, inner, true, Material::kCardboard});
      g.centre = Vec3(cx, cy, z0 + 0.5 * width);
      g.radius2 = r * r + width * width + 1e-4;
      break;
    }
    case SceneKind::kCan:
    {
      const double len = 0.11;
      g.discs.push_back({cx, cy, z0, 0.0, r * r, Material::kMetal, -1, false});
      g.tubes.push_back({cx, cy, z0, z0 + len, r, false, Material::kObject});
      g.centre = Vec3(cx, cy, z0 + 0.5 * len);
      g.radius2 = r * r + 0.25 * len * len + 1e-4;
      break;
    }
    case SceneKind::kSpool:
    case SceneKind::kEmptySlot:
      return;
  }
  addGroup(std::move(g), geometry);
}

// The scene of `p` as primitives: boards, clutter boxes, wall marks, the slot's spool or object, then
// the neighbours, in that order (the ids, and so where anti-aliasing sees an edge, follow it).
SceneGeometry sceneGeometry(const SceneParams& p)
{
  SceneGeometry geometry;
  const double big = 0.5 * p.flange_diameter;
  if (p.back_row.z > 0.0 && p.back_row.z < p.bore_length)
    throw std::invalid_argument("scene: back_row.z (" + std::to_string(p.back_row.z) +
                                " m) must be 0 (no back row) or at least bore_length (" +
                                std::to_string(p.bore_length) + " m): the rows would overlap");
  geometry.wall_z = std::max(0.0, p.back_row.z) + p.bore_length + p.wall_gap;
  geometry.lower_board_top = SpoolRenderer::kHoleHeight - big;
  geometry.lower_board_bottom = geometry.lower_board_top - p.board_thickness;
  geometry.upper_board_bottom = SpoolRenderer::kHoleHeight + big + p.top_board_clearance;
  const double upper_board_top = geometry.upper_board_bottom + p.board_thickness;
  geometry.boxes = {
      {{Vec3(-20.0, geometry.lower_board_bottom, p.board_front), Vec3(20.0, geometry.lower_board_top, geometry.wall_z)},
       Material::kBoard,
       -1},
      {{Vec3(-20.0, geometry.upper_board_bottom, p.board_front), Vec3(20.0, upper_board_top, geometry.wall_z)},
       Material::kBoard,
       -1}};
  for (const ShelfBox& b : p.boxes)
  {
    const double floor = b.upper ? upper_board_top : geometry.lower_board_top;
    geometry.boxes.push_back(
        {{Vec3(b.x - 0.5 * b.width, floor, b.z), Vec3(b.x + 0.5 * b.width, floor + b.height, b.z + b.depth)},
         Material::kClutter,
         static_cast<int>(geometry.clutter_colours.size())});
    geometry.clutter_colours.push_back(toVec(b.colour));
  }
  geometry.next_id = 1 + static_cast<int>(geometry.boxes.size());
  for (const WallMark& m : p.wall_marks)
  {
    // Just in front of the wall, so the wall never wins the depth test against it.
    const double z = geometry.wall_z - 1e-4;
    Group g;
    g.centre = Vec3(m.x, m.y, z);
    g.radius2 = m.radius * m.radius + 1e-4;
    g.discs.push_back({m.x, m.y, z, m.inner_radius * m.inner_radius, m.radius * m.radius, Material::kClutter,
                       static_cast<int>(geometry.clutter_colours.size()), false});
    geometry.clutter_colours.push_back(toVec(m.colour));
    addGroup(std::move(g), geometry);
  }

  if (p.kind == SceneKind::kSpool)
    addSpool(p, 0.0, 0.0, p.label_angle, geometry);
  else
    addObject(p, geometry);
  int count = 0;
  for (const Vec3& centre : neighbourCentres(p))
    addSpool(p, centre.x(), centre.z(), p.label_angle + 1.7 * ++count, geometry);
  if (p.back_row.z > 0.0)
    geometry.back_row_id = geometry.next_id;
  for (const Vec3& centre : backRowCentres(p))
    addSpool(p, centre.x(), centre.z(), p.label_angle + 2.3 * ++count, geometry);
  return geometry;
}

// --- ray casting ---------------------------------------------------------------------------

void intersectBox(const Vec3& o, const Vec3& d, const Vec3& inv, const Box& b, int id, Hit& hit)
{
  const std::array<Vec3, 2>& box = b.bounds;
  double t0 = 0.0;
  double t1 = hit.t;
  int axis = -1;
  double sign = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    if (std::abs(d[a]) < kEps)
    {
      if (o[a] < box[0][a] || o[a] > box[1][a])
        return;
      continue;
    }
    double ta = (box[0][a] - o[a]) * inv[a];
    double tb = (box[1][a] - o[a]) * inv[a];
    double s = -1.0;  // normal of the entry face
    if (ta > tb)
    {
      std::swap(ta, tb);
      s = 1.0;
    }
    if (ta > t0)
    {
      t0 = ta;
      axis = a;
      sign = s;
    }
    t1 = std::min(t1, tb);
    if (t0 > t1)
      return;
  }
  if (axis < 0)
    return;  // the camera is inside the box
  hit.t = t0;
  hit.id = id;
  hit.material = b.material;
  hit.normal = Vec3::Zero();
  hit.normal[axis] = sign;
  hit.owner = b.owner;
}

void intersectDisc(const Vec3& o, const Vec3& d, double inv_dz, const Disc& disc, int id, Hit& hit)
{
  if (d.z() <= kEps)
    return;
  const double t = (disc.z - o.z()) * inv_dz;
  if (t <= kEps || t >= hit.t)
    return;
  const double x = o.x() + t * d.x() - disc.cx;
  const double y = o.y() + t * d.y() - disc.cy;
  const double r2 = x * x + y * y;
  if (r2 < disc.r_in2 || r2 > disc.r_out2)
    return;
  hit.t = t;
  hit.id = id;
  hit.material = disc.material;
  hit.normal = Vec3(0, 0, -1);
  hit.owner = disc.owner;
  hit.textured = disc.textured;
}

void intersectTube(const Vec3& o, const Vec3& d, double a, double inv_a, const Tube& tube, int id, Hit& hit)
{
  if (a < kEps)
    return;
  const double ox = o.x() - tube.cx;
  const double oy = o.y() - tube.cy;
  const double b = ox * d.x() + oy * d.y();
  const double c = ox * ox + oy * oy - tube.r * tube.r;
  const double disc = b * b - a * c;
  if (disc < 0.0)
    return;
  const double root = std::sqrt(disc);
  const double t = (tube.inward ? -b + root : -b - root) * inv_a;
  if (t <= kEps || t >= hit.t)
    return;
  const double z = o.z() + t * d.z();
  if (z < tube.z0 || z > tube.z1)
    return;
  const double sign = tube.inward ? -1.0 : 1.0;
  hit.t = t;
  hit.id = id;
  hit.material = tube.material;
  hit.normal = Vec3(sign * (ox + t * d.x()) / tube.r, sign * (oy + t * d.y()) / tube.r, 0.0);
  hit.owner = -1;
  hit.z_front = tube.z0;
  hit.z_back = tube.z1;
}

// Nearest hit along o + t d (d need not be unit length); o is the camera centre.
Hit castRay(const SceneGeometry& geometry, const CameraFrame& camera, double rod_length, const Vec3& o, const Vec3& d)
{
  // Divisions are the costly part of the tests below: share them across primitives.
  const Vec3 inv = d.cwiseInverse();
  const double inv_d2 = 1.0 / d.squaredNorm();
  const double a_xy = d.x() * d.x() + d.y() * d.y();
  const double inv_a_xy = a_xy > kEps ? 1.0 / a_xy : 0.0;
  Hit hit;
  if (d.z() > kEps)
  {
    hit.t = (geometry.wall_z - o.z()) * inv.z();
    hit.id = 0;
    hit.material = Material::kWall;
    hit.normal = Vec3(0, 0, -1);
  }
  for (std::size_t i = 0; i < geometry.boxes.size(); ++i)
    intersectBox(o, d, inv, geometry.boxes[i], static_cast<int>(i) + 1, hit);
  for (const Group& g : geometry.groups)
  {
    const Vec3 w = g.centre - o;
    const double tc = w.dot(d) * inv_d2;
    if ((w - tc * d).squaredNorm() > g.radius2)
      continue;
    int id = g.first_id;
    for (const Disc& disc : g.discs)
      intersectDisc(o, d, inv.z(), disc, id++, hit);
    for (const Tube& tube : g.tubes)
      intersectTube(o, d, a_xy, inv_a_xy, tube, id++, hit);
  }
  Vec3 rod_normal = Vec3::Zero();
  const double rod_t = pullerRodHit(camera.rotation.transpose() * d, rod_length, &rod_normal);
  if (rod_t < hit.t)
  {
    hit.t = rod_t;
    hit.id = geometry.next_id;
    hit.material = Material::kRod;
    hit.normal = camera.rotation * rod_normal;
    hit.owner = -1;
  }
  return hit;
}

// The light a scene sends back along each camera ray: its geometry, the rays cast through it,
// and the lamps' shading of what they hit.
class Scene
{
public:
  Scene(const SceneParams& params, const CameraFrame& camera)
    : p_(params), camera_(camera), geometry_(sceneGeometry(params))
  {
    setupLights();
    prints_.reserve(params.wall_prints.size());
    for (const WallPrint& print : params.wall_prints)
      prints_.emplace_back(print);
  }

  // Nearest hit along o + t d (d need not be unit length); o is the camera centre.
  Hit trace(const Vec3& o, const Vec3& d) const
  {
    return castRay(geometry_, camera_, p_.puller_rod_length, o, d);
  }

  // Linear BGR radiance (1 = full scale) seen along d; `sub` refines the surface id where the
  // texture has sharp edges (label), so anti-aliasing treats them as edges too. `footprint`
  // is the pixel's size (m) at the hit, for textures that filter themselves.
  Vec3 shade(const Vec3& o, const Vec3& d, const Hit& hit, double footprint, int& sub) const
  {
    const Vec3 lit = unshadowed(o, d, hit, footprint, sub);
    if (geometry_.back_row_id < 0 || hit.id < geometry_.back_row_id || hit.id >= geometry_.next_id)
      return lit;
    const double open = diffuse(hit.normal);
    return open > 0.0 ? lit * (reachingLight(o + hit.t * d, hit.normal) / open) : lit;
  }

private:
  // shade() as if nothing stood between the surface and the lamps or the room: true of the front
  // row, the shelf and the wall (whose board shadows wallRadiance() sets), not of the back row.
  Vec3 unshadowed(const Vec3& o, const Vec3& d, const Hit& hit, double footprint, int& sub) const
  {
    sub = 0;
    const Vec3 pt = o + hit.t * d;
    const Vec3 view = -d.normalized();
    switch (hit.material)
    {
      case Material::kWall:
        return wallRadiance(pt, hit, footprint, sub);
      case Material::kBoard:
      {
        const double grain = 1.0 + 0.08 * std::sin(40.0 * pt.x() + 3.0 * std::sin(13.0 * pt.z()));
        return Vec3(0.38, 0.52, 0.62) * grain * diffuse(hit.normal);
      }
      case Material::kFlange:
        return flangeRadiance(o, pt, view, hit, footprint, sub);
      case Material::kCopper:
        return Vec3(0.18, 0.42, 0.75) * diffuse(hit.normal) +
               Vec3(0.35, 0.55, 0.8) * specular(hit.normal, view, 0.35, 5);
      case Material::kBore:
        return boreRadiance(pt, hit);
      case Material::kClutter:
        return geometry_.clutter_colours[hit.owner] * diffuse(hit.normal);
      case Material::kRod:
        // Turned steel: grey, with a highlight running along the rod.
        return Vec3::Constant(0.45) * diffuse(hit.normal) + Vec3::Constant(specular(hit.normal, view, 0.5, 4));
      case Material::kObject:
        return toVec(p_.object_colour) * diffuse(hit.normal) + Vec3::Constant(specular(hit.normal, view, 0.05, 5));
      case Material::kObjectRim:
        return toVec(p_.object_colour) * 0.8 * diffuse(hit.normal) +
               Vec3::Constant(specular(hit.normal, view, 0.05, 5));
      case Material::kCardboard:
        return Vec3(0.35, 0.5, 0.6) * diffuse(hit.normal);
      case Material::kMetal:
        return lidRadiance(pt, view, hit, sub);
    }
    return Vec3::Zero();
  }

  // Whether anything of the scene lies along the ray from `pt` towards `direction` (unit).
  bool blocked(const Vec3& pt, const Vec3& direction) const
  {
    return castRay(geometry_, camera_, 0.0, pt + 1e-4 * direction, direction).t < kInf;
  }

  // diffuse() at `pt` for what reaches it past the scene's geometry: each lamp only where its
  // shadow ray is free, the room's ambient light in the share of kAmbientRays (cosine-weighted
  // about the normal) that leave the shelf. A back-row face sees the lamps and the room only
  // through the gaps between the front row's flanges and under the upper board.
  double reachingLight(const Vec3& pt, const Vec3& n) const
  {
    double direct = 0.0;
    for (int i = 0; i < 3; ++i)
      if (lamp_weight_[i] > 0.0 && n.dot(lampDirections()[i]) > 0.0 && !blocked(pt, lampDirections()[i]))
        direct += lamp_weight_[i] * n.dot(lampDirections()[i]);
    // Any two unit vectors across the normal: the hemisphere's samples are symmetric about it.
    const Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    const Vec3 u = n.cross(a).normalized();
    const Vec3 w = n.cross(u);
    int open = 0;
    for (int k = 0; k < kAmbientRays; ++k)
    {
      // Fibonacci points on the disc, lifted onto the hemisphere: cosine-weighted directions.
      const double r = std::sqrt((k + 0.5) / kAmbientRays);
      const double phi = k * 2.399963229728653;
      const Vec3 dir = r * std::cos(phi) * u + r * std::sin(phi) * w + std::sqrt(1.0 - r * r) * n;
      open += blocked(pt, dir) ? 0 : 1;
    }
    const double ambient = static_cast<double>(open) / kAmbientRays;
    return light_scale_ * (kAmbientFraction * ambient + (1.0 - kAmbientFraction) * direct / kFrontCosine);
  }

  // The wall behind the shelf: a faint pattern or the topmost print, shaded under and over the
  // boards. A print's border is a surface edge (anti-aliased); its inside filters itself.
  Vec3 wallRadiance(const Vec3& pt, const Hit& hit, double footprint, int& sub) const
  {
    double shadow = 1.0;
    if (pt.y() < geometry_.lower_board_bottom)
      shadow = 0.45;  // inside the compartment below: the board shades it
    else if (pt.y() > geometry_.upper_board_bottom)
      shadow = 0.6;
    sub = shadow < 1.0 ? 1 : 0;
    const bool behind_bore = std::hypot(pt.x(), pt.y() - SpoolRenderer::kHoleHeight) < kPlainWallRadius;
    const auto print = std::find_if(prints_.rbegin(), prints_.rend(),
                                    [&pt](const PrintTexture& t) { return t.contains(pt.x(), pt.y()); });
    if (!behind_bore && print != prints_.rend())
    {
      sub += 2;
      return toVec(print->reflectance(pt.x(), pt.y(), footprint)) * shadow * diffuse(hit.normal);
    }
    const double pattern = 1.0 + 0.05 * std::sin(7.1 * pt.x() + 0.3) * std::sin(5.3 * pt.y());
    return toVec(p_.wall_colour) * pattern * shadow * diffuse(hit.normal);
  }

  // The bore's wall, lit through its openings.
  Vec3 boreRadiance(const Vec3& pt, const Hit& hit) const
  {
    if (p_.bore_falloff > 0.0)
    {
      // A 3.6 cm bore 20 cm long is lit only through its openings: the lamps' ambient light
      // at the front, the lit wall at the back; both die out within a few centimetres.
      const double front = std::exp(-(pt.z() - hit.z_front) / p_.bore_falloff);
      const double back = std::exp(-(hit.z_back - pt.z()) / p_.bore_falloff);
      return Vec3::Constant(p_.bore_reflectance * (front_light_ * front + back_light_ * back));
    }
    // Light enters from the back opening, so the wall darkens towards the front rim but
    // stays lighter than the flange face.
    const double depth = std::clamp((pt.z() - hit.z_front) / p_.bore_length, 0.0, 1.0);
    return Vec3::Constant(p_.bore_reflectance * (0.7 + 0.6 * depth) * light_scale_);
  }

  // A can's lid: a dark recessed groove and a shiny seamed rim.
  Vec3 lidRadiance(const Vec3& pt, const Vec3& view, const Hit& hit, int& sub) const
  {
    const double r = std::hypot(pt.x() - geometry_.object_cx, pt.y() - geometry_.object_cy) / p_.object_radius;
    double albedo = 0.55;
    if (r > 0.8 && r < 0.86)
    {
      albedo = 0.35;
      sub = 1;
    }
    else if (r >= 0.9)
    {
      albedo = 0.7;
      sub = 2;
    }
    return Vec3::Constant(albedo) * diffuse(hit.normal) + Vec3::Constant(specular(hit.normal, view, 0.3, 4));
  }

  void setupLights()
  {
    const std::array<bool, 3>& on = lampSpec(p_.lamps).on;
    double total = 0.0;
    for (int i = 0; i < 3; ++i)
      total += on[i] ? kLampShare[i] : 0.0;
    for (int i = 0; i < 3; ++i)
      lamp_weight_[i] = on[i] ? kLampShare[i] / total : 0.0;
    light_scale_ = sceneIlluminance(p_) / kReferenceLux;
    front_light_ = kAmbientFraction * light_scale_;
    back_light_ = toVec(p_.wall_colour).mean() * diffuse(Vec3(0, 0, -1));
  }

  double diffuse(const Vec3& n) const
  {
    double direct = 0.0;
    for (int i = 0; i < 3; ++i)
      direct += lamp_weight_[i] * std::max(0.0, n.dot(lampDirections()[i]));
    return light_scale_ * (kAmbientFraction + (1.0 - kAmbientFraction) * direct / kFrontCosine);
  }

  // Blinn-Phong highlight; the exponent is a power of two so it costs a few squarings.
  double specular(const Vec3& n, const Vec3& view, double ks, int log2_exponent) const
  {
    double s = 0.0;
    for (int i = 0; i < 3; ++i)
    {
      if (lamp_weight_[i] == 0.0)
        continue;
      double c = std::max(0.0, n.dot((lampDirections()[i] + view).normalized()));
      for (int k = 0; k < log2_exponent; ++k)
        c *= c;
      s += lamp_weight_[i] * c;
    }
    return light_scale_ * ks * s;
  }

  // Box filter of the band [lo, hi] over a pixel footprint [r - half, r + half].
  static double coverage(double r, double half, double lo, double hi)
  {
    return std::max(0.0, std::min(r + half, hi) - std::max(r - half, lo)) / (2.0 * half);
  }

  // The tube lamp's mirror image in a flange face (plane z = pt.z) seen from o: the reflected
  // ray passes the lamp where the straight ray meets the lamp mirrored behind the face.
  double glossStreak(const Vec3& o, const Vec3& pt) const
  {
    const cv::Vec3d& lamp = p_.gloss_lamp;
    const double k = (2.0 * pt.z() - lamp[2] - o.z()) / (pt.z() - o.z());
    const double qx = o.x() + k * (pt.x() - o.x()) - lamp[0];
    const double qy = o.y() + k * (pt.y() - o.y()) - lamp[1];
    const double off = (-qx * std::sin(p_.gloss_lamp_angle) + qy * std::cos(p_.gloss_lamp_angle)) / p_.gloss_spread;
    return p_.gloss * light_scale_ * std::exp(-0.5 * off * off);
  }

  Vec3 flangeRadiance(const Vec3& o, const Vec3& pt, const Vec3& view, const Hit& hit, double footprint, int& sub) const
  {
    Vec3 radiance = flangeColour(pt, hit, footprint, sub) * diffuse(hit.normal) +
                    Vec3::Constant(specular(hit.normal, view, 0.02, 5));
    const bool face = hit.normal.z() < -0.5;
    if (p_.ribs && p_.rib_slope > 0.0 && face && hit.textured && sub == 0)
      radiance = ribFlanks(pt, view, hit, footprint, radiance);
    if (p_.gloss > 0.0 && face && sub == 0)
      radiance += Vec3::Constant(glossStreak(o, pt));
    return radiance;
  }

  // Raised ribs: each flank of a rib is tilted by rib_slope towards or away from the axis, so
  // one flank faces the lamps above (a bright thin circle) and the other faces away (a dark one).
  Vec3 ribFlanks(const Vec3& pt, const Vec3& view, const Hit& hit, double footprint, const Vec3& flat) const
  {
    const SpoolInfo& s = geometry_.spools[hit.owner];
    const double x = pt.x() - s.cx;
    const double y = pt.y() - s.cy;
    const double r = std::hypot(x, y);
    if (r < kEps)
      return flat;
    const double half = 0.5 * std::max(footprint, 1e-4);
    const Vec3 outward(x / r, y / r, 0.0);
    const Vec3 black = Vec3::Constant(p_.flange_reflectance);
    Vec3 radiance = flat;
    for (int side : {-1, 1})  // inner flank faces the axis, outer flank faces away
    {
      double cover = 0.0;
      for (double rib : kRibRadii)
        cover += side < 0 ? coverage(r, half, rib - kRibHalfWidth - kRibFlank, rib - kRibHalfWidth)
                          : coverage(r, half, rib + kRibHalfWidth, rib + kRibHalfWidth + kRibFlank);
      if (cover <= 0.0)
        continue;
      const Vec3 n = (hit.normal * std::cos(p_.rib_slope) + side * outward * std::sin(p_.rib_slope)).normalized();
      const Vec3 flank = black * diffuse(n) + Vec3::Constant(specular(n, view, 0.02 + 0.5 * p_.gloss, 5));
      cover = std::min(cover, 1.0);
      radiance = (1.0 - cover) * radiance + cover * flank;
    }
    return radiance;
  }

  Vec3 flangeColour(const Vec3& pt, const Hit& hit, double footprint, int& sub) const
  {
    const Vec3 black = Vec3::Constant(p_.flange_reflectance);
    if (!hit.textured)
      return black;
    const SpoolInfo& s = geometry_.spools[hit.owner];
    const double x = pt.x() - s.cx;
    const double y = pt.y() - s.cy;
    if (p_.label)
    {
      // Label frame: `along` runs radially, `across` tangentially.
      const double ca = std::cos(s.label_angle);
      const double sa = std::sin(s.label_angle);
      const double along = x * ca + y * sa - p_.label_radius;
      const double across = -x * sa + y * ca;
      if (std::abs(along) < 0.025 && std::abs(across) < 0.035)
      {
        // A few printed lines of "text" in the label's middle.
        const double line = (along + 0.025) / 0.008;
        const int row = static_cast<int>(line);
        const bool text = row >= 1 && row <= 4 && line - row < 0.5 && std::abs(across) < 0.028 - 0.004 * row;
        sub = text ? 3 : 1;
        return text ? Vec3(0.2, 0.2, 0.22) : Vec3(0.78, 0.82, 0.85);
      }
    }
    if (p_.ribs)
    {
      // Each rib's crest catches a little more light. Its 4 mm band is box-filtered over the
      // pixel footprint, so thin ribs far away blend instead of aliasing.
      const double r = std::hypot(x, y);
      const double half = 0.5 * std::max(footprint, 1e-4);
      double crest = 0.0;
      for (double rib : kRibRadii)
        crest += coverage(r, half, rib - kRibHalfWidth, rib + kRibHalfWidth);
      return black + Vec3::Constant(0.02 * std::min(crest, 1.0));
    }
    return black;
  }

  const SceneParams& p_;
  CameraFrame camera_;
  SceneGeometry geometry_;
  std::vector<PrintTexture> prints_;
  std::array<double, 3> lamp_weight_{};
  double light_scale_ = 1.0;
  double front_light_ = 0.0;  // bore: light entering the front opening
  double back_light_ = 0.0;   // bore: light entering the back opening from the lit wall
};

CameraFrame cameraFrame(const CameraPose& pose)
{
  const double planar2 = pose.distance * pose.distance - pose.height * pose.height - pose.lateral * pose.lateral;
  if (!(pose.distance > 0.0) || !(planar2 > 0.0))
    throw std::invalid_argument("camera pose: distance must exceed the lateral and height offsets");
  CameraFrame f;
  f.centre = Vec3(pose.lateral, SpoolRenderer::kHoleHeight + pose.height, -std::sqrt(planar2));
  const double cy = std::cos(pose.yaw);
  const double sy = std::sin(pose.yaw);
  const double cp = std::cos(pose.pitch);
  const double sp = std::sin(pose.pitch);
  const Vec3 forward(sy * cp, -sp, cy * cp);
  const Vec3 right(cy, 0.0, -sy);
  const Vec3 down = right.cross(forward);
  f.rotation.col(0) = right;
  f.rotation.col(1) = down;
  f.rotation.col(2) = forward;
  return f;
}

bool insideImage(const CameraIntrinsics& k, double u, double v)
{
  return u >= -0.5 && u <= k.width - 0.5 && v >= -0.5 && v <= k.height - 0.5;
}

Mat3 intrinsicMatrix(const CameraIntrinsics& k)
{
  Mat3 m;
  m << k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0;
  return m;
}

cv::Matx33d cameraMatrix(const CameraIntrinsics& k)
{
  return {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0};
}

// Where camera-frame points (z > 0) appear in the image the camera delivers: through its lens
// distortion when it has one (OpenCV's model, which is ROS's).
std::vector<cv::Point2d> imagePoints(const CameraIntrinsics& k, const std::vector<cv::Point3d>& points)
{
  std::vector<cv::Point2d> pixels;
  if (k.distorted())
  {
    if (!points.empty())
      cv::projectPoints(points, cv::Vec3d::all(0.0), cv::Vec3d::all(0.0), cameraMatrix(k), k.distortion, pixels);
    return pixels;
  }
  pixels.reserve(points.size());
  for (const cv::Point3d& p : points)
    pixels.emplace_back(k.fx * p.x / p.z + k.cx, k.fy * p.y / p.z + k.cy);
  return pixels;
}

cv::Point2d imagePoint(const CameraIntrinsics& k, const Vec3& p)
{
  return imagePoints(k, {cv::Point3d(p.x(), p.y(), p.z())}).front();
}

// The rays (camera frame, z = 1) through the given pixel positions: their undistorted normalised
// coordinates, so that a ray caster draws the distorted image directly.
std::vector<cv::Point2d> pixelRays(const CameraIntrinsics& k, const std::vector<cv::Point2d>& pixels)
{
  std::vector<cv::Point2d> rays;
  if (k.distorted())
  {
    // OpenCV's default of 5 fixed-point steps leaves ~0.01 px in a C270's corners.
    if (!pixels.empty())
      cv::undistortPoints(pixels, rays, cameraMatrix(k), k.distortion, cv::noArray(), cv::noArray(),
                          cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-9));
    return rays;
  }
  rays.reserve(pixels.size());
  for (const cv::Point2d& p : pixels)
    rays.emplace_back((p.x - k.cx) / k.fx, (p.y - k.cy) / k.fy);
  return rays;
}

// Projects the circle of `radius` around `centre` in the plane z = centre.z; nullopt when part
// of it lies behind the camera (its image is then no ellipse).
// The ellipse of the image conic `q` (p^T q p = 0 for homogeneous pixels p, no lens): its
// semi-axes, the major axis' angle in (-pi/2, pi/2], r and r_vertical into `pc`; returns its centre.
cv::Point2d conicEllipse(const Mat3& q, ProjectedCircle& pc)
{
  const double A = q(0, 0);
  const double B = 2.0 * q(0, 1);
  const double C = q(1, 1);
  const double D = 2.0 * q(0, 2);
  const double E = 2.0 * q(1, 2);
  const double F = q(2, 2);

  Eigen::Matrix2d m;
  m << 2.0 * A, B, B, 2.0 * C;
  const Eigen::Vector2d centre_px = m.inverse() * Eigen::Vector2d(-D, -E);
  const double x0 = centre_px.x();
  const double y0 = centre_px.y();
  const double f0 = A * x0 * x0 + B * x0 * y0 + C * y0 * y0 + D * x0 + E * y0 + F;
  Eigen::Matrix2d quad;
  quad << A, 0.5 * B, 0.5 * B, C;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(quad);
  const Eigen::Vector2d lambda = eig.eigenvalues();  // ascending
  // Larger semi-axis belongs to the eigenvalue of smaller magnitude.
  const int major = std::abs(lambda(0)) < std::abs(lambda(1)) ? 0 : 1;
  pc.semi_major = std::sqrt(-f0 / lambda(major));
  pc.semi_minor = std::sqrt(-f0 / lambda(1 - major));
  pc.angle = std::atan2(eig.eigenvectors()(1, major), eig.eigenvectors()(0, major));
  if (pc.angle > M_PI_2)
    pc.angle -= M_PI;
  else if (pc.angle <= -M_PI_2)
    pc.angle += M_PI;
  pc.r = 0.5 * (pc.semi_major + pc.semi_minor);
  // Rows where the conic's row-quadratic has a double root bound the vertical extent.
  const double qa = B * B - 4.0 * A * C;
  const double qb = 2.0 * B * D - 4.0 * A * E;
  const double qc = D * D - 4.0 * A * F;
  pc.r_vertical = 0.5 * std::sqrt(std::max(0.0, qb * qb - 4.0 * qa * qc)) / std::abs(qa);
  return {x0, y0};
}

std::optional<ProjectedCircle> projectCircle(const CameraIntrinsics& k, const CameraFrame& cam, const Vec3& centre,
                                             double radius)
{
  const Mat3 world_to_cam = cam.rotation.transpose();
  const Vec3 c = world_to_cam * (centre - cam.centre);
  const Vec3 e1 = world_to_cam.col(0);
  const Vec3 e2 = world_to_cam.col(1);
  ProjectedCircle pc;
  std::vector<cv::Point3d> rim;
  rim.reserve(kRimSamples);
  for (int i = 0; i < kRimSamples; ++i)
  {
    const double a = 2.0 * M_PI * i / kRimSamples;
    const Vec3 p = c + radius * (std::cos(a) * e1 + std::sin(a) * e2);
    if (p.z() < 1e-3)
      return std::nullopt;
    rim.emplace_back(p.x(), p.y(), p.z());
  }
  const std::vector<cv::Point2d> rim_px = imagePoints(k, rim);
  const auto inside =
      std::count_if(rim_px.begin(), rim_px.end(), [&k](const cv::Point2d& q) { return insideImage(k, q.x, q.y); });
  pc.visible_fraction = static_cast<double>(inside) / kRimSamples;
  const cv::Point2d centre_px3d = imagePoint(k, c);
  pc.centre_x = centre_px3d.x;
  pc.centre_y = centre_px3d.y;

  // The plane-to-image homography maps the conic x^2 + y^2 = r^2 to the image conic.
  Mat3 h;
  h.col(0) = e1;
  h.col(1) = e2;
  h.col(2) = c;
  h = intrinsicMatrix(k) * h;
  const Mat3 h_inv = h.inverse();
  Mat3 q = h_inv.transpose() * Eigen::Vector3d(1.0, 1.0, -radius * radius).asDiagonal() * h_inv;
  q /= q.norm();
  const cv::Point2d undistorted_centre = conicEllipse(q, pc);
  const double x0 = undistorted_centre.x;
  const double y0 = undistorted_centre.y;
  // The ellipse centre where the lens puts it.
  const cv::Point2d ellipse_centre =
      k.distorted() ? imagePoint(k, Vec3((x0 - k.cx) / k.fx, (y0 - k.cy) / k.fy, 1.0)) : cv::Point2d(x0, y0);
  pc.x = ellipse_centre.x;
  pc.y = ellipse_centre.y;
  return pc;
}

// How the camera sees the target's front opening: the fraction through which it sees past the
// back opening (the lens), the lens' centroid in the image, and whether the puller rod hides
// any of the opening.
struct OpeningView
{
  double lit_fraction = 0.0;
  cv::Point2d lens{SpoolDetection::kNaN, SpoolDetection::kNaN};
  bool occluded = false;
};

// True where the ray from the camera along `d` meets the front flange face of a back-row spool
// (`back_row`: their centres), which is black: the bore's see-through shows no light there.
bool backRowBlocks(const SceneParams& scene, const std::vector<Vec3>& back_row, const CameraFrame& cam, const Vec3& d)
{
  const double big = 0.5 * scene.flange_diameter;
  const double hole = 0.5 * scene.hole_diameter;
  for (const Vec3& centre : back_row)
  {
    const Vec3 r = cam.centre + d * ((centre.z() - cam.centre.z()) / d.z());
    const double off = std::hypot(r.x() - centre.x(), r.y() - centre.y());
    if (off <= big && off > hole)
      return true;
  }
  return false;
}

OpeningView openingView(const CameraIntrinsics& k, const CameraFrame& cam, const SceneParams& scene)
{
  constexpr int kGrid = 64;
  const double hole_radius = 0.5 * scene.hole_diameter;
  const Mat3 world_to_cam = cam.rotation.transpose();
  OpeningView view;
  int total = 0;
  std::vector<cv::Point3d> lens;  // camera frame
  const std::vector<Vec3> back_row = backRowCentres(scene);
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j)
    {
      const double x = hole_radius * (2.0 * (j + 0.5) / kGrid - 1.0);
      const double y = hole_radius * (2.0 * (i + 0.5) / kGrid - 1.0);
      if (x * x + y * y > hole_radius * hole_radius)
        continue;
      ++total;
      const Vec3 p(x, SpoolRenderer::kHoleHeight + y, 0.0);
      const Vec3 d = p - cam.centre;
      const Vec3 pc = world_to_cam * d;
      view.occluded |= pullerRodHit(pc, scene.puller_rod_length) < 1.0;
      const Vec3 q = cam.centre + d * ((scene.bore_length - cam.centre.z()) / d.z());
      if (std::hypot(q.x(), q.y() - SpoolRenderer::kHoleHeight) <= hole_radius &&
          !backRowBlocks(scene, back_row, cam, d))
        lens.emplace_back(pc.x(), pc.y(), pc.z());
    }
  view.lit_fraction = total > 0 ? static_cast<double>(lens.size()) / total : 0.0;
  if (lens.empty())
    return view;
  cv::Point2d lens_sum(0.0, 0.0);
  for (const cv::Point2d& p : imagePoints(k, lens))
    lens_sum += p;
  view.lens = lens_sum / static_cast<double>(lens.size());
  return view;
}

// Brightness left at pixel (u, v) after vignetting, which darkens away from the principal point.
double vignette(const SceneParams& scene, const CameraIntrinsics& k, double u, double v)
{
  const double half_diag2 = 0.25 * (double(k.width) * k.width + double(k.height) * k.height);
  return 1.0 - scene.vignetting * (((u - k.cx) * (u - k.cx) + (v - k.cy) * (v - k.cy)) / half_diag2);
}

// A linear level (DN, 255 = full scale) as the camera's output encodes it.
double gammaEncode(const SceneParams& scene, double level)
{
  if (scene.gamma == 1.0)
    return level;
  return 255.0 * std::pow(std::clamp(level / 255.0, 0.0, 1.0), scene.gamma);
}

// Defocus: a uniform disc of `radius` px (soft-edged so sub-pixel radii still blur).
void defocus(cv::Mat& radiance, double radius)
{
  if (radius < 0.25)
    return;
  const int reach = static_cast<int>(std::ceil(radius));
  cv::Mat kernel(2 * reach + 1, 2 * reach + 1, CV_32F);
  for (int y = -reach; y <= reach; ++y)
    for (int x = -reach; x <= reach; ++x)
      kernel.at<float>(y + reach, x + reach) =
          static_cast<float>(std::clamp(radius + 0.5 - std::hypot(x, y), 0.0, 1.0));
  kernel /= cv::sum(kernel)[0];
  cv::filter2D(radiance, radiance, -1, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
}

// The exposure integrates the image while it moves: the mean of copies along the smear. The
// smear is centred on the mid-exposure image, where the ground truth puts the rims.
void motionBlur(cv::Mat& radiance, const SceneParams& scene, const CameraIntrinsics& k, double length)
{
  if (length < 0.25)
    return;
  const int copies = static_cast<int>(std::ceil(length)) + 2;
  const double half_diag = 0.5 * std::hypot(k.width, k.height);
  cv::Mat sum = cv::Mat::zeros(radiance.size(), radiance.type());
  cv::Mat moved;
  for (int i = 0; i < copies; ++i)
  {
    const double s = static_cast<double>(i) / (copies - 1) - 0.5;
    cv::Matx23d m(1.0, 0.0, s * length * std::cos(scene.motion_blur_angle), 0.0, 1.0,
                  s * length * std::sin(scene.motion_blur_angle));
    if (scene.motion_blur_radial)
    {
      // Driving forward magnifies the image about the principal point.
      const double zoom = 1.0 + s * length / half_diag;
      m = cv::Matx23d(zoom, 0.0, k.cx * (1.0 - zoom), 0.0, zoom, k.cy * (1.0 - zoom));
    }
    cv::warpAffine(radiance, moved, m, radiance.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    sum += moved;
  }
  radiance = sum / copies;
}

// Centre-weighted auto exposure (the centre counts 9x the corners): the gain (within the
// sensor's range) that brings the weighted mean of the output grey to the target, metered on a
// reduced image.
double autoExposureGain(const cv::Mat& radiance, const SceneParams& scene, const CameraIntrinsics& k)
{
  constexpr int kMeterWidth = 64;
  const int mw = std::min(kMeterWidth, radiance.cols);
  const int mh = std::max(1, radiance.rows * mw / radiance.cols);
  cv::Mat small;
  cv::resize(radiance, small, cv::Size(mw, mh), 0.0, 0.0, cv::INTER_AREA);
  const double su = static_cast<double>(radiance.cols) / mw;
  const double sv = static_cast<double>(radiance.rows) / mh;
  const double sigma2 = std::pow(0.15 * radiance.cols, 2);
  std::vector<double> weight(static_cast<std::size_t>(mw * mh));
  std::vector<cv::Vec3d> level(weight.size());  // DN at unit gain
  double weight_sum = 0.0;
  for (int y = 0; y < mh; ++y)
    for (int x = 0; x < mw; ++x)
    {
      const double u = (x + 0.5) * su - 0.5;
      const double v = (y + 0.5) * sv - 0.5;
      const double du = u - 0.5 * (radiance.cols - 1);
      const double dv = v - 0.5 * (radiance.rows - 1);
      const std::size_t i = static_cast<std::size_t>(y * mw + x);
      weight[i] = 1.0 + 8.0 * std::exp(-0.5 * (du * du + dv * dv) / sigma2);
      weight_sum += weight[i];
      const cv::Vec3f& rad = small.at<cv::Vec3f>(y, x);
      const double g = 255.0 * scene.exposure * vignette(scene, k, u, v);
      for (int ch = 0; ch < 3; ++ch)
        level[i][ch] = g * rad[ch] * scene.white_balance[ch];
    }
  auto meanGrey = [&](double gain)
  {
    double sum = 0.0;
    for (std::size_t i = 0; i < weight.size(); ++i)
      sum +=
          weight[i] * (0.114 * gammaEncode(scene, gain * level[i][0]) + 0.587 * gammaEncode(scene, gain * level[i][1]) +
                       0.299 * gammaEncode(scene, gain * level[i][2]));
    return sum / (weight_sum * 255.0);
  };
  // The mean grows with the gain: bisect on its logarithm.
  double lo = std::log(1.0 / 8.0);
  double hi = std::log(scene.auto_exposure_max_gain);
  for (int i = 0; i < 24; ++i)
  {
    const double mid = 0.5 * (lo + hi);
    (meanGrey(std::exp(mid)) < scene.auto_exposure_target ? lo : hi) = mid;
  }
  return std::exp(0.5 * (lo + hi));
}

std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t salt)
{
  // SplitMix64 finaliser: decorrelates nearby seeds.
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (salt + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return (z ^ (z >> 31)) | 1ULL;
}

// A number, or null where it is undefined (NaN).
Json number(double value)
{
  return std::isfinite(value) ? Json(value) : Json(nullptr);
}

// {"x": .., "y": .., "z": ..}, or null when undefined.
Json xyz(double x, double y, double z)
{
  if (!std::isfinite(x))
    return nullptr;
  return {{"x", x}, {"y", y}, {"z", z}};
}

// The intrinsics and lens (the size is written beside them, at the top level).
Json cameraJson(const CameraIntrinsics& c)
{
  return {{"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy}, {"distortion", c.distortion}};
}

Json poseJson(const CameraPose& p)
{
  return {{"distance", p.distance}, {"lateral", p.lateral}, {"height", p.height}, {"yaw", p.yaw}, {"pitch", p.pitch}};
}

Json circleJson(const std::optional<ProjectedCircle>& c)
{
  if (!c)
    return nullptr;
  return {{"x", number(c->x)},
          {"y", number(c->y)},
          {"r", number(c->r)},
          {"r_vertical", number(c->r_vertical)},
          {"semi_major", number(c->semi_major)},
          {"semi_minor", number(c->semi_minor)},
          {"angle", number(c->angle)},
          {"centre_x", number(c->centre_x)},
          {"centre_y", number(c->centre_y)},
          {"visible_fraction", number(c->visible_fraction)}};
}

}  // namespace

const char* toString(LampCondition lamps)
{
  return lampSpec(lamps).name;
}

const char* toString(SceneKind kind)
{
  static constexpr std::array<const char*, 5> kNames = {"spool", "empty_slot", "plate", "tape_roll", "can"};
  static_assert(kNames.size() == static_cast<std::size_t>(SceneKind::kCan) + 1, "one name per kind");
  return kNames[static_cast<std::size_t>(kind)];
}

void lampRange(LampCondition lamps, double& min_lux, double& max_lux)
{
  min_lux = lampSpec(lamps).min_lux;
  max_lux = lampSpec(lamps).max_lux;
}

SpoolRenderer::SpoolRenderer(const CameraIntrinsics& camera) : camera_(camera)
{
  if (!camera_.valid())
    throw std::invalid_argument("SpoolRenderer: invalid camera intrinsics");
}

namespace
{
// rad, between a spool's `axis` and the line of sight to its face centre `c` (camera frame).
double viewAngle(const Vec3& axis, const Vec3& c)
{
  return std::acos(std::clamp(std::abs(axis.dot(c)) / (axis.norm() * c.norm()), 0.0, 1.0));
}

// The slot spool's pose truth from its bore's front centre `c` and its axis (the world's z) in
// the camera optical frame: position, depth, range, bearing, the puller reference, the axis'
// angles and the puller's clearance at both ends of the bore. The puller axis runs along z
// through (0, kPullerOffsetY, 0).
void poseTruth(const CameraIntrinsics& camera, const Vec3& c, const Vec3& axis, const SceneParams& scene,
               GroundTruth& gt)
{
  gt.position = cv::Point3d(c.x(), c.y(), c.z());
  gt.distance = c.z();
  gt.range = c.norm();
  gt.reference = imagePoint(camera, Vec3(0.0, SpoolRenderer::kPullerOffsetY, c.z()));
  gt.yaw = std::atan(c.x() / c.z());
  gt.lateral_offset = c.x();

  gt.axis = cv::Vec3d(axis.x(), axis.y(), axis.z());
  gt.axis_angle = std::acos(std::clamp(axis.z(), -1.0, 1.0));
  gt.axis_yaw = std::atan2(axis.x(), axis.z());
  gt.view_angle = viewAngle(axis, c);
  // The puller axis' miss of the bore axis in the plane across the bore at `end` (on its axis).
  const Vec3 puller(0.0, SpoolRenderer::kPullerOffsetY, 0.0);
  auto missAt = [&](const Vec3& end)
  {
    const Vec3 through = puller + Vec3::UnitZ() * ((end - puller).dot(axis) / axis.z());
    return (through - end).norm();
  };
  gt.puller_miss = missAt(c);
  const double tolerance = 0.5 * (scene.hole_diameter - SpoolRenderer::kPullerDiameter);
  gt.puller_clearance = tolerance - std::max(gt.puller_miss, missAt(c + scene.bore_length * axis));
  gt.puller_clears = gt.puller_clearance >= 0.0;
  gt.aligned = gt.puller_clears && gt.distance >= SpoolRenderer::kAlignedDistanceMin &&
               gt.distance <= SpoolRenderer::kAlignedDistanceMax;
}
}  // namespace

GroundTruth SpoolRenderer::groundTruth(const SceneParams& scene, const CameraPose& pose) const
{
  const CameraFrame cam = cameraFrame(pose);
  GroundTruth gt;
  gt.kind = scene.kind;
  gt.lamps = scene.lamps;
  gt.illuminance = sceneIlluminance(scene);
  gt.pose = pose;
  gt.camera = camera_;

  const Mat3 world_to_cam = cam.rotation.transpose();
  // Every spool on the shelf lies along the world's z.
  const Vec3 axis = world_to_cam * Vec3::UnitZ();
  const double big = 0.5 * scene.flange_diameter;
  for (const Vec3& centre : neighbourCentres(scene))
    if (auto pc = projectCircle(camera_, cam, centre, big))
    {
      gt.spool_centre_in_view |= insideImage(camera_, pc->centre_x, pc->centre_y);
      const Vec3 c = world_to_cam * (centre - cam.centre);
      gt.neighbours.push_back({*pc, c.z(), std::atan(c.x() / c.z()), false, viewAngle(axis, c)});
    }
  for (const Vec3& centre : backRowCentres(scene))
    if (auto pc = projectCircle(camera_, cam, centre, big))
    {
      const Vec3 c = world_to_cam * (centre - cam.centre);
      gt.neighbours.push_back({*pc, c.z(), std::atan(c.x() / c.z()), true, viewAngle(axis, c)});
    }
  if (scene.kind != SceneKind::kSpool)
    return gt;

  const Vec3 centre(0.0, kHoleHeight, 0.0);
  gt.flange = projectCircle(camera_, cam, centre, big);
  gt.hole = projectCircle(camera_, cam, centre, 0.5 * scene.hole_diameter);
  if (!gt.flange || !gt.hole)
    throw std::invalid_argument("camera pose: the front flange is not in front of the camera");
  gt.spool_centre_in_view |= insideImage(camera_, gt.flange->centre_x, gt.flange->centre_y);
  gt.flange_half_visible = gt.flange->visible_fraction >= 0.5;
  const OpeningView opening = openingView(camera_, cam, scene);
  gt.hole_occluded = opening.occluded;
  gt.hole_in_view = gt.hole->visible_fraction >= 1.0 && !opening.occluded;
  gt.hole_lit_fraction = opening.lit_fraction;
  gt.hole_lens = opening.lens;
  gt.bore_visible = gt.hole_lit_fraction > 0.0;

  poseTruth(camera_, world_to_cam * (centre - cam.centre), axis, scene, gt);
  return gt;
}

namespace
{
// Linear BGR radiance along `ray` (normalised image coordinates, z = 1), and `key`: the surface
// it hits, id * 4 + its texture's sub-id, or -1 for none.
Vec3 sampleRay(const Scene& world, const CameraFrame& cam, double fx, const cv::Point2d& ray, int& key)
{
  const Vec3 d = cam.rotation * Vec3(ray.x, ray.y, 1.0);
  const Hit hit = world.trace(cam.centre, d);
  if (hit.id < 0)
  {
    key = -1;
    return Vec3(Vec3::Zero());
  }
  int sub = 0;
  const double footprint = hit.t * d.norm() / fx;
  const Vec3 colour = world.shade(cam.centre, d, hit, footprint, sub);
  key = hit.id * 4 + sub;
  return colour;
}

// 1 where a pixel's surface key differs from a 4-neighbour's (both pixels of the pair).
cv::Mat surfaceEdges(const cv::Mat& keys)
{
  const int w = keys.cols;
  const int h = keys.rows;
  cv::Mat edge = cv::Mat::zeros(h, w, CV_8U);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
    {
      const int k = keys.at<int>(v, u);
      if (u + 1 < w && keys.at<int>(v, u + 1) != k)
        edge.at<uchar>(v, u) = edge.at<uchar>(v, u + 1) = 1;
      if (v + 1 < h && keys.at<int>(v + 1, u) != k)
        edge.at<uchar>(v, u) = edge.at<uchar>(v + 1, u) = 1;
    }
  return edge;
}

// The scene's linear radiance at each pixel of `camera` (CV_32FC3): one ray per pixel, then
// kSuperSamples^2 rays averaged where the visible surface (or a texture edge) changes.
cv::Mat radianceImage(const Scene& world, const CameraFrame& cam, const CameraIntrinsics& camera)
{
  const int w = camera.width;
  const int h = camera.height;
  std::vector<cv::Point2d> pixels;
  pixels.reserve(static_cast<std::size_t>(w) * h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      pixels.emplace_back(u, v);
  const std::vector<cv::Point2d> rays = pixelRays(camera, pixels);
  cv::Mat radiance(h, w, CV_32FC3);
  cv::Mat keys(h, w, CV_32S);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
    {
      const Vec3 c = sampleRay(world, cam, camera.fx, rays[static_cast<std::size_t>(v) * w + u], keys.at<int>(v, u));
      radiance.at<cv::Vec3f>(v, u) = cv::Vec3f(c.x(), c.y(), c.z());
    }

  const cv::Mat edge = surfaceEdges(keys);
  pixels.clear();
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      if (edge.at<uchar>(v, u))
        for (int i = 0; i < kSuperSamples; ++i)
          for (int j = 0; j < kSuperSamples; ++j)
            pixels.emplace_back(u + (j + 0.5) / kSuperSamples - 0.5, v + (i + 0.5) / kSuperSamples - 0.5);
  const std::vector<cv::Point2d> sub_rays = pixelRays(camera, pixels);
  std::size_t next = 0;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
    {
      if (!edge.at<uchar>(v, u))
        continue;
      Vec3 sum = Vec3::Zero();
      int unused = 0;
      for (int k = 0; k < kSuperSamples * kSuperSamples; ++k)
        sum += sampleRay(world, cam, camera.fx, sub_rays[next++], unused);
      sum /= kSuperSamples * kSuperSamples;
      radiance.at<cv::Vec3f>(v, u) = cv::Vec3f(sum.x(), sum.y(), sum.z());
    }
  return radiance;
}

// What the webcam makes of the radiance: lens blur (optical, defocus, motion), vignetting, auto
// exposure, white balance, then shot and read noise (both grow with the gain), gamma,
// quantisation and JPEG. `radiance` is blurred in place.
cv::Mat webcamImage(cv::Mat& radiance, const SceneParams& scene, const CameraIntrinsics& camera)
{
  const int w = camera.width;
  const int h = camera.height;
  if (scene.blur_sigma > 0.05)
    cv::GaussianBlur(radiance, radiance, cv::Size(), scene.blur_sigma);
  const double per_480_rows = h / 480.0;
  defocus(radiance, scene.defocus_radius * per_480_rows);
  motionBlur(radiance, scene, camera, scene.motion_blur * per_480_rows);
  const double auto_gain = scene.auto_exposure_target > 0.0 ? autoExposureGain(radiance, scene, camera) : 1.0;
  cv::Mat noise(h, w, CV_32FC3);
  cv::RNG rng(mixSeed(scene.seed, 1));
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  cv::Mat image(h, w, CV_8UC3);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
    {
      const double gain = 255.0 * scene.exposure * auto_gain * vignette(scene, camera, u, v);
      const cv::Vec3f& rad = radiance.at<cv::Vec3f>(v, u);
      const cv::Vec3f& n = noise.at<cv::Vec3f>(v, u);
      cv::Vec3b& out = image.at<cv::Vec3b>(v, u);
      for (int ch = 0; ch < 3; ++ch)
      {
        const double level = gain * rad[ch] * scene.white_balance[ch];
        // Electrons carry shot noise, the amplifier adds read noise; the gain scales both.
        const double sigma =
            scene.noise_sigma * std::sqrt((auto_gain * std::max(level, 0.0) + 16.0 * auto_gain * auto_gain) / 144.0);
        out[ch] = cv::saturate_cast<uchar>(gammaEncode(scene, level + sigma * n[ch]));
      }
    }
  if (scene.jpeg_quality > 0)
  {
    std::vector<uchar> buffer;
    cv::imencode(".jpg", image, buffer, {cv::IMWRITE_JPEG_QUALITY, scene.jpeg_quality});
    image = cv::imdecode(buffer, cv::IMREAD_COLOR);
  }
  return image;
}
}  // namespace

RenderedFrame SpoolRenderer::render(const SceneParams& scene, const CameraPose& pose) const
{
  RenderedFrame frame;
  frame.truth = groundTruth(scene, pose);
  const CameraFrame cam = cameraFrame(pose);
  const Scene world(scene, cam);
  cv::Mat radiance = radianceImage(world, cam, camera_);
  frame.image = webcamImage(radiance, scene, camera_);
  return frame;
}

namespace
{
// The lamps over the shelf (thesis 4.2.5) and the exposure.
void drawLight(cv::RNG& rng, SceneParams& s)
{
  s.lamps = static_cast<LampCondition>(rng.uniform(0, 4));
  double lo = 0.0;
  double hi = 0.0;
  lampRange(s.lamps, lo, hi);
  s.illuminance = rng.uniform(lo, hi);
  s.exposure = rng.uniform(0.85, 1.15);
}

// The spool's make (bore, flange, winding, faces) and the spools beside it.
void drawSpools(cv::RNG& rng, SceneParams& s)
{
  s.bore_length = rng.uniform(0.18, 0.22);
  s.flange_thickness = rng.uniform(0.008, 0.015);
  s.winding_diameter = rng.uniform(0.22, 0.32);
  s.flange_reflectance = rng.uniform(0.05, 0.08);
  s.bore_reflectance = rng.uniform(0.16, 0.24);
  s.ribs = rng.uniform(0.0, 1.0) < 0.5;
  s.label = rng.uniform(0.0, 1.0) < 0.4;
  s.label_angle = rng.uniform(0.0, 2.0 * M_PI);
  s.label_radius = rng.uniform(0.085, 0.12);
  for (int side : {-1, 1})
  {
    const int count = rng.uniform(0, 3);
    for (int i = 0; i < count; ++i)
      s.neighbours.push_back({side, rng.uniform(0.01, 0.06), rng.uniform(-0.02, 0.02)});
  }
}

// The look-alike in a negative scene: its size by kind, and its colour and place (drawn for every
// kind, so that the draws after them do not depend on the kind).
void drawLookAlike(cv::RNG& rng, SceneParams& s)
{
  switch (s.kind)
  {
    case SceneKind::kPlate:
      s.object_radius = rng.uniform(0.09, 0.15);
      break;
    case SceneKind::kTapeRoll:
      s.object_radius = rng.uniform(0.048, 0.065);
      break;
    case SceneKind::kCan:
      s.object_radius = rng.uniform(0.033, 0.05);
      break;
    case SceneKind::kSpool:
    case SceneKind::kEmptySlot:
      break;
  }
  // Objects come in any colour, black included (the hardest look-alike of a flange).
  const double grey = rng.uniform(0.0, 1.0) < 0.25 ? rng.uniform(0.04, 0.1) : rng.uniform(0.3, 0.9);
  s.object_colour = cv::Vec3d(grey * rng.uniform(0.6, 1.0), grey * rng.uniform(0.6, 1.0), grey * rng.uniform(0.6, 1.0));
  s.object_offset_x = rng.uniform(-0.08, 0.08);
  s.object_depth = rng.uniform(0.0, 0.1);
}

// The shelf: the wall behind the slot and the boards above and below.
void drawShelf(cv::RNG& rng, SceneParams& s)
{
  s.wall_gap = rng.uniform(0.03, 0.2);
  s.board_front = rng.uniform(-0.05, 0.0);
  s.top_board_clearance = rng.uniform(0.04, 0.15);
  const double wall = rng.uniform(0.6, 0.85);
  s.wall_colour = cv::Vec3d(wall * rng.uniform(0.9, 1.0), wall * rng.uniform(0.95, 1.0), wall);
}

// The main set's camera: blur, noise, MJPEG, vignetting, the sRGB-like tone curve.
void drawImaging(cv::RNG& rng, SceneParams& s)
{
  s.blur_sigma = rng.uniform(0.3, 0.9);
  s.noise_sigma = rng.uniform(1.0, 4.0);
  s.jpeg_quality = rng.uniform(0.0, 1.0) < 0.7 ? rng.uniform(70, 96) : 0;
  s.vignetting = rng.uniform(0.05, 0.25);
  // A webcam encodes light about as sRGB does (drawn last: the draws above keep their values).
  s.gamma = rng.uniform(0.4, 0.5);
}
}  // namespace

// The draws keep one order (light, spools, look-alike, shelf, imaging): a seed gives the scene it
// always gave.
SceneParams randomScene(SceneKind kind, std::uint64_t seed)
{
  cv::RNG rng(mixSeed(seed, 2));
  SceneParams s;
  s.kind = kind;
  s.seed = seed;
  drawLight(rng, s);
  drawSpools(rng, s);
  drawLookAlike(rng, s);
  drawShelf(rng, s);
  drawImaging(rng, s);
  return s;
}

namespace
{
// True with probability p.
bool chance(cv::RNG& rng, double p)
{
  return rng.uniform(0.0, 1.0) < p;
}

// The hard set's webcam: exposure, gain noise, white balance, blur, MJPEG, and the wall it meters.
void drawWebcam(cv::RNG& rng, SceneParams& s)
{
  // Webcam: auto exposure lifts whatever fills the centre to mid grey, with the gain's noise.
  s.auto_exposure_target = rng.uniform(0.35, 0.55);
  s.auto_exposure_max_gain = rng.uniform(6.0, 16.0);
  s.gamma = rng.uniform(0.4, 0.6);
  s.white_balance = cv::Vec3d(rng.uniform(0.8, 1.2), 1.0, rng.uniform(0.8, 1.2));
  s.noise_sigma = rng.uniform(1.5, 4.0);
  s.vignetting = rng.uniform(0.1, 0.4);
  s.blur_sigma = rng.uniform(0.3, 1.0);
  s.defocus_radius = chance(rng, 0.4) ? rng.uniform(0.5, 2.5) : 0.0;
  if (chance(rng, 0.4))
  {
    s.motion_blur = rng.uniform(1.0, 6.0);
    s.motion_blur_radial = chance(rng, 0.6);
    s.motion_blur_angle = chance(rng, 0.5) ? 0.0 : 0.5 * M_PI;
  }
  s.jpeg_quality = chance(rng, 0.85) ? rng.uniform(50, 91) : 0;

  // A dark wall (or one the centre-weighted metering ignores) makes black faces mid grey.
  if (chance(rng, 0.4))
    s.wall_colour *= rng.uniform(0.15, 0.45);
}

// The hard set's flange faces: matte to glossy, ribs, labels, and the bore's shading.
void drawFaces(cv::RNG& rng, SceneParams& s)
{
  // Faces from matte to glossy, ribbed, labelled.
  s.flange_reflectance = rng.uniform(0.04, 0.1);
  s.ribs = chance(rng, 0.7);
  s.rib_slope = rng.uniform(0.3, 0.9);
  s.label = chance(rng, 0.5);
  if (chance(rng, 0.6))
  {
    s.gloss = rng.uniform(0.1, 0.6);
    s.gloss_lamp =
        cv::Vec3d(rng.uniform(-0.4, 0.4), SpoolRenderer::kHoleHeight + rng.uniform(-0.3, 0.4), -rng.uniform(0.5, 1.5));
    s.gloss_lamp_angle = rng.uniform(-0.6, 0.6);
    s.gloss_spread = rng.uniform(0.04, 0.15);
  }
  s.bore_falloff = rng.uniform(0.005, 0.015);
}

// The hard set's clutter: wall marks and boxes.
void drawClutter(cv::RNG& rng, SceneParams& s)
{
  // Clutter: discs and rings on the wall (not behind the bore, whose see-through shows the wall)
  // and boxes on the boards beside the slot.
  auto colour = [&rng]
  {
    const double grey = rng.uniform(0.03, 0.9);
    return cv::Vec3d(grey * rng.uniform(0.5, 1.0), grey * rng.uniform(0.5, 1.0), grey * rng.uniform(0.5, 1.0));
  };
  const int marks = rng.uniform(0, 9);
  for (int i = 0; i < marks; ++i)
  {
    WallMark m;
    m.radius = rng.uniform(0.01, 0.2);
    m.inner_radius = chance(rng, 0.5) ? m.radius * rng.uniform(0.3, 0.9) : 0.0;
    do
    {
      m.x = rng.uniform(-0.8, 0.8);
      m.y = SpoolRenderer::kHoleHeight + rng.uniform(-0.4, 0.4);
    } while (std::hypot(m.x, m.y - SpoolRenderer::kHoleHeight) < m.radius + 0.1);
    m.colour = colour();
    s.wall_marks.push_back(m);
  }
  const int boxes = rng.uniform(0, 4);
  for (int i = 0; i < boxes; ++i)
  {
    ShelfBox b;
    b.upper = chance(rng, 0.5);
    b.width = rng.uniform(0.05, 0.3);
    b.height = rng.uniform(0.04, b.upper ? 0.3 : 0.2);
    b.depth = rng.uniform(0.05, 0.2);
    b.z = rng.uniform(0.0, std::max(0.0, s.bore_length + s.wall_gap - b.depth));
    // Boxes below stand clear of the target's flange; above the board nothing is in the way.
    const double side = chance(rng, 0.5) ? 1.0 : -1.0;
    b.x = b.upper ? rng.uniform(-0.7, 0.7) : side * (0.5 * s.flange_diameter + 0.5 * b.width + rng.uniform(0.0, 0.5));
    b.colour = colour();
    s.boxes.push_back(b);
  }
}

// The hard set's prints (issue 28's textured real scenes): a mural over the whole wall on half
// the scenes, and 1-5 prints of 20-100 x 15-80 cm on three in four.
void drawPrints(cv::RNG& rng, SceneParams& s)
{
  auto kind = [&rng] { return static_cast<PrintKind>(rng.uniform(0, 5)); };
  if (chance(rng, 0.5))
  {
    WallPrint mural;
    mural.kind = kind();
    mural.x = rng.uniform(-0.3, 0.3);
    mural.y = SpoolRenderer::kHoleHeight;
    mural.width = 2.6;
    mural.height = 1.4;
    mural.seed = rng.uniform(1, 1 << 30);
    s.wall_prints.push_back(mural);
  }
  if (!chance(rng, 0.75))
    return;
  for (int i = rng.uniform(1, 6); i > 0; --i)
  {
    WallPrint print;
    print.kind = kind();
    print.width = rng.uniform(0.2, 1.0);
    print.height = rng.uniform(0.15, 0.8);
    print.x = rng.uniform(-1.0, 1.0);
    print.y = SpoolRenderer::kHoleHeight + rng.uniform(-0.6, 0.6);
    print.seed = rng.uniform(1, 1 << 30);
    s.wall_prints.push_back(print);
  }
}

}  // namespace

void packShelf(std::uint64_t seed, SceneParams& scene)
{
  cv::RNG rng(mixSeed(seed, 5));
  const bool touching = chance(rng, 0.5);
  scene.neighbours.clear();
  for (int side : {-1, 1})
    for (int i = rng.uniform(1, 4); i > 0; --i)
      scene.neighbours.push_back({side, touching ? 0.0 : rng.uniform(0.002, 0.015), rng.uniform(-0.02, 0.02)});
  if (scene.kind != SceneKind::kSpool || !chance(rng, 0.7))
    return;
  scene.back_row.z = scene.bore_length + rng.uniform(0.0, 0.06);
  scene.back_row.gap = rng.uniform(0.0, 0.05);
  scene.back_row.offset = rng.uniform(-0.5, 0.5) * (scene.flange_diameter + scene.back_row.gap);
}

SceneParams randomHardScene(SceneKind kind, std::uint64_t seed)
{
  SceneParams s = randomScene(kind, seed);
  cv::RNG rng(mixSeed(seed, 3));
  // One stream of draws, in this order: a seed gives the same scene as before the split.
  drawWebcam(rng, s);
  drawFaces(rng, s);
  drawClutter(rng, s);
  // The puller rod reaches 12-30 cm ahead of the camera (the set may shorten it to keep the
  // hole clear).
  s.puller_rod_length = chance(rng, 0.8) ? rng.uniform(0.12, 0.3) : 0.0;
  // Their own stream: the draws above give the scenes they gave before the prints.
  cv::RNG print_rng(mixSeed(seed, 4));
  drawPrints(print_rng, s);
  return s;
}

nlohmann::ordered_json groundTruthJson(const GroundTruth& t)
{
  Json neighbours = Json::array();
  for (const NeighbourTruth& n : t.neighbours)
    neighbours.push_back({{"flange", circleJson(n.flange)},
                          {"distance", number(n.distance)},
                          {"yaw", number(n.yaw)},
                          {"back_row", n.back_row},
                          {"view_angle", number(n.view_angle)}});
  return {{"kind", toString(t.kind)},
          {"lamps", toString(t.lamps)},
          {"illuminance", number(t.illuminance)},
          {"width", t.camera.width},
          {"height", t.camera.height},
          {"camera", cameraJson(t.camera)},
          {"pose", poseJson(t.pose)},
          {"distance", number(t.distance)},
          {"range", number(t.range)},
          {"position", xyz(t.position.x, t.position.y, t.position.z)},
          {"yaw", number(t.yaw)},
          {"lateral_offset", number(t.lateral_offset)},
          {"flange", circleJson(t.flange)},
          {"hole", circleJson(t.hole)},
          {"reference", std::isfinite(t.reference.x) ? Json{{"x", t.reference.x}, {"y", t.reference.y}} : Json()},
          {"flange_half_visible", t.flange_half_visible},
          {"hole_in_view", t.hole_in_view},
          {"hole_occluded", t.hole_occluded},
          {"bore_visible", t.bore_visible},
          {"hole_lit_fraction", t.hole_lit_fraction},
          {"hole_lens", std::isfinite(t.hole_lens.x) ? Json{{"x", t.hole_lens.x}, {"y", t.hole_lens.y}} : Json()},
          {"puller_miss", number(t.puller_miss)},
          {"puller_clearance", number(t.puller_clearance)},
          {"axis", xyz(t.axis[0], t.axis[1], t.axis[2])},
          {"axis_angle", number(t.axis_angle)},
          {"axis_yaw", number(t.axis_yaw)},
          {"view_angle", number(t.view_angle)},
          {"puller_clears", t.puller_clears},
          {"aligned", t.aligned},
          {"spool_centre_in_view", t.spool_centre_in_view},
          {"neighbours", neighbours}};
}

}  // namespace spool_vision
