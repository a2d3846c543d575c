#include "omnipoint/data/synth/scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "omnipoint/data/synth/scene_builder.h"

namespace omnipoint::data::synth {

SceneKind parse_scene_kind(const std::string& name) {
  if (name == "indoor") return SceneKind::kIndoor;
  if (name == "outdoor") return SceneKind::kOutdoor;
  if (name == "object") return SceneKind::kObject;
  throw std::invalid_argument("scene kind '" + name + "': expected one of indoor, outdoor, object");
}

std::string scene_kind_name(SceneKind kind) {
  switch (kind) {
    case SceneKind::kIndoor:
      return "indoor";
    case SceneKind::kOutdoor:
      return "outdoor";
    case SceneKind::kObject:
      return "object";
  }
  return "unknown";
}

namespace {
using Mat3 = std::array<std::array<double, 3>, 3>;

Mat3 multiply(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}
}  // namespace

Pose make_pose(const Vec3& position, double yaw, double pitch, double roll) {
  const double cy = std::cos(yaw), sy = std::sin(yaw);
  const double cp = std::cos(pitch), sp = std::sin(pitch);
  const double cr = std::cos(roll), sr = std::sin(roll);
  const Mat3 about_world_z{{{cy, -sy, 0}, {sy, cy, 0}, {0, 0, 1}}};
  const Mat3 level_camera{{{1, 0, 0}, {0, 0, 1}, {0, -1, 0}}};
  const Mat3 about_camera_x{{{1, 0, 0}, {0, cp, -sp}, {0, sp, cp}}};
  const Mat3 about_camera_z{{{cr, -sr, 0}, {sr, cr, 0}, {0, 0, 1}}};
  Pose pose;
  pose.position = position;
  pose.yaw = yaw;
  pose.pitch = pitch;
  pose.roll = roll;
  pose.rotation =
      multiply(multiply(about_world_z, level_camera), multiply(about_camera_x, about_camera_z));
  return pose;
}

Scene make_scene(SceneKind kind, std::uint64_t seed) {
  switch (kind) {
    case SceneKind::kIndoor:
      return make_indoor_scene(seed);
    case SceneKind::kOutdoor:
      return make_outdoor_scene(seed);
    case SceneKind::kObject:
      return make_object_scene(seed);
  }
  throw std::invalid_argument("unknown scene kind");
}

int add_material(Scene& scene, Pattern pattern, const Vec3& a, const Vec3& b, double scale) {
  scene.materials.push_back(Material{pattern, a, b, scale});
  return static_cast<int>(scene.materials.size()) - 1;
}

Vec3 jitter_color(Random& rng, const Vec3& base, double amount) {
  Vec3 c;
  const double brightness = rng.uniform(1.0 - amount, 1.0 + amount);
  for (int i = 0; i < 3; ++i)
    c[i] = std::clamp(base[i] * brightness * rng.uniform(1.0 - amount / 2, 1.0 + amount / 2), 0.0,
                      1.0);
  return c;
}

int add_random_prop_material(Scene& scene, Random& rng) {
  static const Vec3 palette[] = {{0.55, 0.12, 0.1}, {0.15, 0.3, 0.6},   {0.2, 0.45, 0.2},
                                 {0.8, 0.7, 0.45},  {0.35, 0.35, 0.38}, {0.85, 0.85, 0.8},
                                 {0.6, 0.4, 0.2},   {0.7, 0.55, 0.1},   {0.4, 0.2, 0.45}};
  const Vec3 a = jitter_color(rng, palette[rng.integer(0, 8)], 0.25);
  const Vec3 b = jitter_color(rng, palette[rng.integer(0, 8)], 0.25);
  const Vec3 dark{a[0] * 0.6, a[1] * 0.6, a[2] * 0.6};
  switch (rng.integer(0, 5)) {
    case 0:
      return add_material(scene, Pattern::kWood, a, dark, rng.uniform(0.4, 1.0));
    case 1:
      return add_material(scene, Pattern::kStripes, a, b, rng.uniform(0.05, 0.3));
    case 2:
      return add_material(scene, Pattern::kChecker, a, b, rng.uniform(0.05, 0.25));
    default:
      return add_material(scene, Pattern::kNoise, a, dark, rng.uniform(0.1, 0.5));
  }
}

Primitive& add_box(Scene& scene, int material, const Vec3& center, const Vec3& half_size,
                   double yaw) {
  Primitive p;
  p.shape = Shape::kBox;
  p.material = material;
  p.center = center;
  p.half_size = half_size;
  p.yaw = yaw;
  scene.primitives.push_back(p);
  return scene.primitives.back();
}

Primitive& add_sphere(Scene& scene, int material, const Vec3& center, double radius) {
  Primitive p;
  p.shape = Shape::kSphere;
  p.material = material;
  p.center = center;
  p.radius = radius;
  scene.primitives.push_back(p);
  return scene.primitives.back();
}

Primitive& add_cylinder(Scene& scene, int material, const Vec3& center, const Vec3& axis,
                        double radius, double half_length) {
  const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  Primitive p;
  p.shape = Shape::kCylinder;
  p.material = material;
  p.center = center;
  p.axis = {axis[0] / n, axis[1] / n, axis[2] / n};
  p.radius = radius;
  p.half_size = {radius, radius, half_length};
  scene.primitives.push_back(p);
  return scene.primitives.back();
}

Primitive& add_plane(Scene& scene, int material, const Vec3& point, const Vec3& normal) {
  const double n = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
  Primitive p;
  p.shape = Shape::kPlane;
  p.material = material;
  p.center = point;
  p.axis = {normal[0] / n, normal[1] / n, normal[2] / n};
  scene.primitives.push_back(p);
  return scene.primitives.back();
}

}  // namespace omnipoint::data::synth

namespace omnipoint::data::synth {

RoomMaterials add_room_materials(Scene& scene, Random& rng) {
  static const Vec3 woods[] = {{0.55, 0.35, 0.18}, {0.7, 0.5, 0.3}, {0.4, 0.25, 0.12}};
  static const Vec3 paints[] = {
      {0.85, 0.83, 0.78}, {0.8, 0.75, 0.65}, {0.65, 0.75, 0.8}, {0.75, 0.8, 0.7}, {0.9, 0.85, 0.8}};
  RoomMaterials m{};
  const Vec3 wood = jitter_color(rng, woods[rng.integer(0, 2)], 0.15);
  switch (rng.integer(0, 3)) {
    case 0:
    case 1:
      m.floor = add_material(scene, Pattern::kWood, wood,
                             {wood[0] * 0.6, wood[1] * 0.6, wood[2] * 0.6}, rng.uniform(1.5, 2.5));
      break;
    case 2: {
      const double scale = rng.uniform(0.3, 0.6);
      m.floor = add_material(scene, Pattern::kTiles, jitter_color(rng, {0.75, 0.72, 0.68}, 0.2),
                             {0.35, 0.33, 0.3}, scale);
      break;
    }
    default: {
      const double scale = rng.uniform(0.3, 0.5);
      const Vec3 dark = jitter_color(rng, {0.2, 0.2, 0.22}, 0.2);
      m.floor = add_material(scene, Pattern::kChecker, jitter_color(rng, {0.8, 0.8, 0.78}, 0.1),
                             dark, scale);
    }
  }
  const Vec3 paint = jitter_color(rng, paints[rng.integer(0, 4)], 0.1);
  const Vec3 shade{paint[0] * 0.85, paint[1] * 0.85, paint[2] * 0.85};
  switch (rng.integer(0, 4)) {
    case 0:
      m.walls = add_material(scene, Pattern::kStripes, paint, shade, rng.uniform(0.15, 0.4));
      break;
    case 1: {
      const double scale = rng.uniform(0.22, 0.3);
      m.walls = add_material(scene, Pattern::kBricks, jitter_color(rng, {0.6, 0.3, 0.2}, 0.2),
                             {0.75, 0.72, 0.68}, scale);
      break;
    }
    default:
      m.walls = add_material(scene, Pattern::kNoise, paint, shade, rng.uniform(0.5, 2.0));
  }
  m.ceiling = add_material(scene, Pattern::kNoise, {0.92, 0.92, 0.9}, {0.82, 0.82, 0.8}, 1.0);
  return m;
}

int add_room(Scene& scene, const RoomMaterials& materials, double hx, double hy, double height) {
  // The wall box reaches a little below the floor and above the ceiling, so the slabs'
  // visible faces (z = 0 and z = height) never coincide with a face of the box.
  add_box(scene, materials.walls, {0, 0, height / 2}, {hx, hy, height / 2 + 0.05});
  const int walls = static_cast<int>(scene.primitives.size()) - 1;
  add_box(scene, materials.floor, {0, 0, -0.1}, {hx, hy, 0.1});
  add_box(scene, materials.ceiling, {0, 0, height + 0.1}, {hx, hy, 0.1});
  return walls;
}

void randomize_sky(Scene& scene, Random& rng) {
  scene.sky.zenith = jitter_color(rng, {0.25, 0.45, 0.85}, 0.2);
  scene.sky.horizon = jitter_color(rng, {0.78, 0.85, 0.92}, 0.08);
  scene.sky.cloud_cover = rng.uniform(0.0, 0.9);
  scene.sky.noise_seed = rng.seed32();
}

double add_table(Scene& scene, Random& rng, double x, double y, double yaw, int material) {
  const double hl = rng.uniform(0.4, 0.9), hw = rng.uniform(0.3, 0.5);
  const double height = rng.uniform(0.7, 0.78), top = 0.03, leg = 0.03;
  const double c = std::cos(yaw), s = std::sin(yaw);
  add_box(scene, material, {x, y, height - top}, {hl, hw, top}, yaw);
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0}) {
      const double lx = sx * (hl - 0.06), ly = sy * (hw - 0.06);
      add_box(scene, material, {x + c * lx - s * ly, y + s * lx + c * ly, (height - 2 * top) / 2},
              {leg, leg, (height - 2 * top) / 2}, yaw);
    }
  return std::sqrt(hl * hl + hw * hw);
}

double add_chair(Scene& scene, Random& rng, double x, double y, double yaw, int material) {
  const double half = rng.uniform(0.2, 0.25), seat = rng.uniform(0.42, 0.48);
  const double c = std::cos(yaw), s = std::sin(yaw);
  add_box(scene, material, {x, y, seat}, {half, half, 0.03}, yaw);
  // The back stands on the chair's local -y edge.
  add_box(scene, material, {x + s * (half - 0.02), y - c * (half - 0.02), seat + 0.25},
          {half, 0.02, 0.25}, yaw);
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0}) {
      const double lx = sx * (half - 0.03), ly = sy * (half - 0.03);
      add_cylinder(scene, material, {x + c * lx - s * ly, y + s * lx + c * ly, seat / 2}, {0, 0, 1},
                   0.02, seat / 2);
    }
  return half * 1.5;
}

}  // namespace omnipoint::data::synth
