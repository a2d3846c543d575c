// Object-centric scenes: a table in a room with a handful of objects (balls, boxes, cans,
// cups, lying rolls) on it, seen from nearby and looking down at it.
#include <cmath>
#include <vector>

#include "omnipoint/data/synth/scene_builder.h"

namespace omnipoint::data::synth {
namespace {
constexpr double kPi = 3.14159265358979323846;
}

Scene make_object_scene(std::uint64_t seed) {
  Scene scene;
  scene.kind = SceneKind::kObject;
  scene.seed = seed;
  Random rng(seed, 3);
  scene.texture_seed = rng.seed32();
  randomize_sky(scene, rng);

  const double hx = rng.uniform(2.5, 4.5), hy = rng.uniform(2.5, 4.5),
               height = rng.uniform(2.5, 3.2);
  add_room(scene, add_room_materials(scene, rng), hx, hy, height);

  // The table: a top (wood, plain or cloth-like) on four legs.
  const double hl = rng.uniform(0.6, 1.0), hw = rng.uniform(0.4, 0.6),
               top_z = rng.uniform(0.72, 0.78);
  const Vec3 wood = jitter_color(rng, {0.55, 0.38, 0.22}, 0.25);
  const int table = rng.chance(0.6) ? add_material(scene, Pattern::kWood, wood,
                                                   {wood[0] * 0.6, wood[1] * 0.6, wood[2] * 0.6},
                                                   rng.uniform(1.0, 2.0))
                                    : add_random_prop_material(scene, rng);
  add_box(scene, table, {0, 0, top_z - 0.025}, {hl, hw, 0.025});
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      add_box(scene, table, {sx * (hl - 0.06), sy * (hw - 0.06), (top_z - 0.05) / 2},
              {0.03, 0.03, (top_z - 0.05) / 2});

  // Objects standing on the table top, not overlapping.
  struct Spot {
    double x, y, r;
  };
  std::vector<Spot> spots;
  const int wanted = rng.integer(3, 8);
  for (int attempts = 0; static_cast<int>(spots.size()) < wanted && attempts < 80; ++attempts) {
    const int kind = rng.integer(0, 4);
    const double size = rng.uniform(0.04, 0.13);
    const double x = rng.uniform(-hl + size + 0.02, hl - size - 0.02);
    const double y = rng.uniform(-hw + size + 0.02, hw - size - 0.02);
    bool free = true;
    for (const auto& s : spots)
      free = free && std::hypot(s.x - x, s.y - y) > s.r + size * 1.5 + 0.01;
    if (!free) continue;
    const int material = add_random_prop_material(scene, rng);
    switch (kind) {
      case 0:
        add_sphere(scene, material, {x, y, top_z + size}, size);
        break;
      case 1: {
        const double h = size * rng.uniform(0.5, 2.0);
        const double yaw = rng.uniform(-kPi, kPi);
        const double depth = size * rng.uniform(0.5, 1.0);
        add_box(scene, material, {x, y, top_z + h}, {size, depth, h}, yaw);
        break;
      }
      case 2: {  // a can or a cup
        const double h = size * rng.uniform(1.0, 3.0);
        add_cylinder(scene, material, {x, y, top_z + h}, {0, 0, 1}, size * 0.7, h);
        break;
      }
      case 3: {  // a roll lying on its side
        const double yaw = rng.uniform(-kPi, kPi), r = size * 0.5;
        add_cylinder(scene, material, {x, y, top_z + r}, {std::cos(yaw), std::sin(yaw), 0}, r,
                     size);
        break;
      }
      default: {  // a stack: a box with a ball on it
        const double h = size * 0.6;
        add_box(scene, material, {x, y, top_z + h}, {size, size, h}, rng.uniform(-kPi, kPi));
        add_sphere(scene, add_random_prop_material(scene, rng), {x, y, top_z + 2 * h + size * 0.6},
                   size * 0.6);
      }
    }
    spots.push_back({x, y, size * 1.5});
  }

  // The camera around the table, looking at its centre from above.
  const double azimuth = rng.uniform(-kPi, kPi), range = rng.uniform(0.9, 1.8);
  const Vec3 eye{range * std::cos(azimuth), range * std::sin(azimuth),
                 top_z + rng.uniform(0.25, 0.8)};
  const Vec3 target{rng.uniform(-0.15, 0.15), rng.uniform(-0.1, 0.1), top_z + 0.05};
  const double dx = target[0] - eye[0], dy = target[1] - eye[1], dz = target[2] - eye[2];
  // One draw a statement: the order of draws inside one call is the compiler's (random.h).
  const double roll = rng.uniform(-0.06, 0.06);
  const double pitch = std::atan2(dz, std::hypot(dx, dy)) + rng.uniform(-0.08, 0.08);
  const double yaw = std::atan2(-dx, dy) + rng.uniform(-0.1, 0.1);
  scene.pose = make_pose(eye, yaw, pitch, roll);

  const int lamps = rng.integer(1, 2);
  for (int l = 0; l < lamps; ++l) {
    Light light;
    const double a = rng.uniform(-kPi, kPi), r = rng.uniform(0.5, 2.0);
    light.position = {r * std::cos(a), r * std::sin(a), height - 0.3};
    const double power = rng.uniform(3.0, 5.0) / lamps;
    light.color = jitter_color(rng, {power, power * 0.95, power * 0.85}, 0.1);
    scene.lights.push_back(light);
  }
  scene.ambient = jitter_color(rng, {0.2, 0.2, 0.22}, 0.15);
  return scene;
}

}  // namespace omnipoint::data::synth
