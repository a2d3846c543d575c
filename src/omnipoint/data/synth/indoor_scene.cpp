// Indoor rooms: walls, floor and ceiling with a door (a corridor behind it) and windows
// (sky and a garden outside), furniture as boxes, cylinders and spheres, ceiling lights and
// sometimes sunlight through the windows.
#include <cmath>
#include <vector>

#include "omnipoint/data/synth/scene_builder.h"

namespace omnipoint::data::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Footprint {
  double x, y, radius;
};

bool is_free(const std::vector<Footprint>& taken, double x, double y, double radius) {
  for (const auto& f : taken)
    if (std::hypot(f.x - x, f.y - y) < f.radius + radius) return false;
  return true;
}

// A door or window on wall (axis, side) of the room; for doors a corridor box behind it.
void add_opening(Scene& scene, Random& rng, int walls, double hx, double hy, double height,
                 int axis, int side, bool door, int corridor_material) {
  const double along_half = axis == 0 ? hy : hx;  // the wall's half length
  const double width = door ? rng.uniform(0.8, 1.0) : rng.uniform(0.8, std::min(2.2, along_half));
  const double bottom = door ? 0.0 : rng.uniform(0.7, 1.0);
  const double top = door ? rng.uniform(2.0, std::min(2.2, height - 0.1))
                          : std::min(height - 0.2, bottom + rng.uniform(1.0, 1.6));
  const double centre = rng.uniform(-along_half + width / 2 + 0.2, along_half - width / 2 - 0.2);
  // Opening rectangles are relative to the wall box centre, whose z is height / 2.
  const double z0 = bottom - height / 2, z1 = top - height / 2;
  Opening hole{axis, side, {centre - width / 2, z0}, {centre + width / 2, z1}};
  scene.primitives[walls].openings.push_back(hole);
  if (!door) return;
  // The corridor starts 2 cm behind the wall (a thin wall instead of coincident faces).
  const double depth = rng.uniform(1.5, 4.0), half_width = rng.uniform(0.7, 1.3);
  const double wall = (axis == 0 ? hx : hy) + 0.02;
  const double corridor_height = top + 0.4;
  Vec3 center{0, 0, corridor_height / 2 - 0.05}, half{0, 0, corridor_height / 2 + 0.05};
  center[axis] = side * (wall + depth / 2);
  half[axis] = depth / 2;
  center[1 - axis] = centre;
  half[1 - axis] = half_width;
  auto& corridor = add_box(scene, corridor_material, center, half);
  const double cz = center[2];
  corridor.openings.push_back(
      Opening{axis, -side, {hole.lo[0] - centre, bottom - cz}, {hole.hi[0] - centre, top - cz}});
}

}  // namespace

Scene make_indoor_scene(std::uint64_t seed) {
  Scene scene;
  scene.kind = SceneKind::kIndoor;
  scene.seed = seed;
  Random rng(seed, 1);
  scene.texture_seed = rng.seed32();
  randomize_sky(scene, rng);

  const double hx = rng.uniform(1.6, 4.0), hy = rng.uniform(1.6, 4.0);
  const double height = rng.uniform(2.4, 3.2);
  const auto room = add_room_materials(scene, rng);
  const int walls = add_room(scene, room, hx, hy, height);

  // Outside: a lawn below the windows and a few trees.
  const int grass = add_material(scene, Pattern::kNoise, jitter_color(rng, {0.25, 0.45, 0.15}, 0.2),
                                 {0.15, 0.3, 0.1}, 1.5);
  add_plane(scene, grass, {0, 0, -0.5}, {0, 0, 1});
  const int plaster = add_material(
      scene, Pattern::kNoise, jitter_color(rng, {0.8, 0.78, 0.72}, 0.1), {0.65, 0.63, 0.6}, 1.0);
  const int door_wall = rng.integer(0, 3);
  add_opening(scene, rng, walls, hx, hy, height, door_wall / 2, door_wall % 2 ? 1 : -1, true,
              plaster);
  const int windows = rng.integer(0, 2);
  for (int w = 0, wall = (door_wall + 1) % 4; w < windows; ++w, wall = (wall + 1 + w) % 4)
    add_opening(scene, rng, walls, hx, hy, height, wall / 2, wall % 2 ? 1 : -1, false, plaster);
  const int bark = add_material(scene, Pattern::kNoise, {0.35, 0.25, 0.15}, {0.2, 0.15, 0.1}, 0.3);
  const int leaves = add_material(scene, Pattern::kNoise, {0.2, 0.4, 0.12}, {0.1, 0.25, 0.08}, 0.5);
  for (int t = 0; t < 4; ++t) {
    const double angle = rng.uniform(0, 2 * kPi), range = rng.uniform(6, 14);
    const double x = range * std::cos(angle), y = range * std::sin(angle);
    add_cylinder(scene, bark, {x, y, 1.0}, {0, 0, 1}, 0.15, 1.5);
    add_sphere(scene, leaves, {x, y, 3.5}, rng.uniform(1.2, 2.0));
  }

  // The camera first, so that furniture keeps clear of it.
  const double cx = rng.uniform(-hx + 0.6, hx - 0.6), cy = rng.uniform(-hy + 0.6, hy - 0.6);
  const double cz = std::min(rng.uniform(1.0, 1.8), height - 0.4);
  // Look towards a random point of the room at least 1.5 m away (not into a nearby wall).
  double tx = -cx, ty = -cy;
  for (int attempt = 0; attempt < 8; ++attempt) {
    const double x = rng.uniform(-hx, hx), y = rng.uniform(-hy, hy);
    if (std::hypot(x - cx, y - cy) >= 1.5) {
      tx = x;
      ty = y;
      break;
    }
  }
  // One draw a statement: the order of draws inside one call is the compiler's (random.h).
  const double roll = rng.uniform(-0.08, 0.08);
  const double pitch = rng.uniform(-0.3, 0.2);
  const double yaw = std::atan2(-(tx - cx), ty - cy) + rng.uniform(-0.3, 0.3);
  scene.pose = make_pose({cx, cy, cz}, yaw, pitch, roll);
  std::vector<Footprint> taken{{cx, cy, 0.8}};

  const int items = rng.integer(4, 9);
  for (int i = 0, attempts = 0; i < items && attempts < 60; ++attempts) {
    const int kind = rng.integer(0, 7);
    const int material = add_random_prop_material(scene, rng);
    const double yaw = rng.chance(0.6) ? rng.integer(0, 3) * kPi / 2 : rng.uniform(-kPi, kPi);
    if (kind <= 1) {  // a cabinet, shelf or wardrobe against a wall
      const double w = rng.uniform(0.3, 1.0), d = rng.uniform(0.18, 0.3), h = rng.uniform(0.4, 1.1);
      const int wall = rng.integer(0, 3);
      const int axis = wall / 2;
      const double side = wall % 2 ? 1.0 : -1.0;
      const double along = axis == 0 ? hy : hx, across = axis == 0 ? hx : hy;
      const double t = rng.uniform(-along + w, along - w);
      const double x = axis == 0 ? side * (across - d) : t, y = axis == 0 ? t : side * (across - d);
      const double radius = std::hypot(w, d);
      if (along - w <= -along + w || !is_free(taken, x, y, radius)) continue;
      add_box(scene, material, {x, y, h}, axis == 0 ? Vec3{d, w, h} : Vec3{w, d, h});
      taken.push_back({x, y, radius});
    } else {
      const double x = rng.uniform(-hx + 0.5, hx - 0.5), y = rng.uniform(-hy + 0.5, hy - 0.5);
      const double probe = kind == 2 ? 1.0 : 0.5;
      if (!is_free(taken, x, y, probe)) continue;
      double radius = probe;
      switch (kind) {
        case 2:
          radius = add_table(scene, rng, x, y, yaw, material);
          break;
        case 3:
          radius = add_chair(scene, rng, x, y, yaw, material);
          break;
        case 4: {  // sofa or bed: a base and a back
          const double hl = rng.uniform(0.7, 1.0), hw = rng.uniform(0.4, 0.5);
          add_box(scene, material, {x, y, 0.22}, {hl, hw, 0.22}, yaw);
          add_box(scene, material,
                  {x + std::sin(yaw) * (hw - 0.1), y - std::cos(yaw) * (hw - 0.1), 0.5},
                  {hl, 0.1, 0.5}, yaw);
          radius = std::hypot(hl, hw);
          break;
        }
        case 5: {  // a floor lamp
          add_cylinder(scene, material, {x, y, 0.8}, {0, 0, 1}, 0.025, 0.8);
          const double shade_radius = rng.uniform(0.15, 0.25);
          const int shade = add_random_prop_material(scene, rng);
          add_cylinder(scene, shade, {x, y, 1.6}, {0, 0, 1}, shade_radius, 0.15);
          add_cylinder(scene, material, {x, y, 0.02}, {0, 0, 1}, 0.15, 0.02);
          radius = 0.3;
          break;
        }
        case 6: {  // a ball or a round pouf
          const double r = rng.uniform(0.12, 0.35);
          if (rng.chance(0.5))
            add_sphere(scene, material, {x, y, r}, r);
          else
            add_cylinder(scene, material, {x, y, r}, {0, 0, 1}, r * 1.2, r);
          radius = r * 1.2;
          break;
        }
        default: {  // a pillar or a rug
          if (rng.chance(0.4)) {
            const double r = rng.uniform(0.12, 0.3);
            add_cylinder(scene, material, {x, y, height / 2}, {0, 0, 1}, r, height / 2);
            radius = r;
          } else {
            const double hl = rng.uniform(0.6, 1.2), hw = rng.uniform(0.4, 0.8);
            add_box(scene, material, {x, y, 0.005}, {hl, hw, 0.005}, yaw);
            radius = 0.0;  // flat: anything may stand on it
          }
        }
      }
      taken.push_back({x, y, radius});
    }
    ++i;
  }
  // Pictures on the walls.
  for (int p = rng.integer(0, 3); p > 0; --p) {
    const int wall = rng.integer(0, 3), axis = wall / 2;
    const double side = wall % 2 ? 1.0 : -1.0;
    const double across = axis == 0 ? hx : hy, along = axis == 0 ? hy : hx;
    const double w = rng.uniform(0.2, 0.6), h = rng.uniform(0.2, 0.5);
    const double t = rng.uniform(-along + 0.7, along - 0.7), z = rng.uniform(1.3, 1.8);
    const int art = add_random_prop_material(scene, rng);
    add_box(scene, art,
            axis == 0 ? Vec3{side * (across - 0.015), t, z} : Vec3{t, side * (across - 0.015), z},
            axis == 0 ? Vec3{0.015, w, h} : Vec3{w, 0.015, h});
  }

  const int lamps = rng.integer(1, 2);
  for (int l = 0; l < lamps; ++l) {
    Light light;
    light.position = {rng.uniform(-hx + 0.5, hx - 0.5), rng.uniform(-hy + 0.5, hy - 0.5),
                      height - 0.3};
    const double power = rng.uniform(2.5, 4.5) / lamps;
    light.color = jitter_color(rng, {power, power * 0.93, power * 0.82}, 0.1);
    scene.lights.push_back(light);
  }
  if (windows > 0 && rng.chance(0.7)) {
    const double azimuth = rng.uniform(-kPi, kPi), elevation = rng.uniform(0.3, 0.8);
    Light sun;
    sun.directional = true;
    sun.position = {std::cos(elevation) * std::cos(azimuth),
                    std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
    sun.color = {1.0, 0.95, 0.85};
    scene.lights.push_back(sun);
  }
  scene.ambient = jitter_color(rng, {0.22, 0.22, 0.24}, 0.15);
  return scene;
}

}  // namespace omnipoint::data::synth
