// Outdoor streets: an asphalt road with lane markings along the y axis, kerbed sidewalks,
// rows of buildings with window facades, poles, trees and parked cars; sunlight with
// shadows, sky at infinity and atmospheric haze.
#include <cmath>

#include "omnipoint/data/synth/scene_builder.h"

namespace omnipoint::data::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kStreetHalfLength = 150.0;

// A car along the street at (x, y), heading +y or -y: body, cabin and two axles whose
// ends are the wheels.
void add_car(Scene& scene, Random& rng, double x, double y, int paint, int glass, int tyre) {
  const double hl = rng.uniform(1.9, 2.4), hw = rng.uniform(0.85, 0.95);
  const double wheel = rng.uniform(0.3, 0.36);
  add_box(scene, paint, {x, y, wheel + 0.35}, {hw, hl, 0.35});
  const double cabin_shift = rng.uniform(-0.3, 0.2);
  add_box(scene, glass, {x, y + cabin_shift, wheel + 0.7 + 0.22}, {hw - 0.06, hl * 0.55, 0.22});
  for (double end : {-1.0, 1.0})
    add_cylinder(scene, tyre, {x, y + end * (hl - 0.65), wheel}, {1, 0, 0}, wheel, hw + 0.02);
}

}  // namespace

Scene make_outdoor_scene(std::uint64_t seed) {
  Scene scene;
  scene.kind = SceneKind::kOutdoor;
  scene.seed = seed;
  Random rng(seed, 2);
  scene.texture_seed = rng.seed32();
  randomize_sky(scene, rng);
  scene.fog_distance = rng.uniform(120, 400);

  const double road = rng.uniform(3.5, 6.5), walk = rng.uniform(2.0, 4.0);
  const int asphalt = add_material(
      scene, Pattern::kNoise, jitter_color(rng, {0.3, 0.3, 0.31}, 0.15), {0.2, 0.2, 0.21}, 0.6);
  add_plane(scene, asphalt, {0, 0, 0}, {0, 0, 1});
  const double paving_scale = rng.uniform(0.4, 0.8);
  const int paving =
      add_material(scene, Pattern::kTiles, jitter_color(rng, {0.62, 0.6, 0.56}, 0.15),
                   {0.4, 0.39, 0.37}, paving_scale);
  for (double side : {-1.0, 1.0})
    add_box(scene, paving, {side * (road + walk / 2), 0, 0.075},
            {walk / 2, kStreetHalfLength, 0.075});
  const int marking =
      add_material(scene, Pattern::kNoise, {0.9, 0.9, 0.85}, {0.75, 0.75, 0.7}, 0.3);
  const double dash = rng.uniform(1.5, 3.0), period = dash + rng.uniform(3.0, 6.0);
  for (double y = -60; y < 60; y += period)
    add_box(scene, marking, {0, y, 0.003}, {0.07, dash / 2, 0.003});

  // The camera: on the road or the sidewalk, mostly looking along the street.
  const bool on_walk = rng.chance(0.3);
  double cam_x = 0;
  if (on_walk) {
    const double side = rng.choice_sign();
    cam_x = side * (road + rng.uniform(0.5, walk - 0.5));
  } else {
    cam_x = rng.uniform(-road + 1.0, road - 1.0);
  }
  const double cam_y = rng.uniform(-20, 20);
  const double cam_z = (on_walk ? 0.15 : 0.0) + rng.uniform(1.4, 2.2);
  double heading = 0;
  if (rng.chance(0.8)) {
    const double along = rng.chance(0.5) ? 0.0 : kPi;
    heading = along + rng.uniform(-0.5, 0.5);
  } else {
    heading = rng.uniform(-kPi, kPi);
  }
  // One draw a statement: the order of draws inside one call is the compiler's (random.h).
  const double roll = rng.uniform(-0.05, 0.05);
  const double pitch = rng.uniform(-0.2, 0.12);
  scene.pose = make_pose({cam_x, cam_y, cam_z}, heading, pitch, roll);

  // Buildings in two rows, with small gaps between them.
  static const Vec3 walls[] = {{0.75, 0.7, 0.6},
                               {0.6, 0.35, 0.25},
                               {0.8, 0.78, 0.75},
                               {0.55, 0.55, 0.58},
                               {0.85, 0.75, 0.55}};
  for (double side : {-1.0, 1.0}) {
    for (double y = -kStreetHalfLength; y < kStreetHalfLength;) {
      const double width = rng.uniform(8, 25), depth = rng.uniform(8, 20);
      const double height = rng.uniform(6, 35), setback = rng.uniform(0, 2);
      const Vec3 wall = jitter_color(rng, walls[rng.integer(0, 4)], 0.15);
      int material = 0;
      if (rng.chance(0.75)) {
        const double scale = rng.uniform(2.8, 3.6);
        material = add_material(scene, Pattern::kFacade, wall,
                                jitter_color(rng, {0.2, 0.25, 0.3}, 0.3), scale);
      } else {
        material =
            add_material(scene, Pattern::kBricks, wall, {0.7, 0.68, 0.65}, rng.uniform(0.22, 0.3));
      }
      const double x = side * (road + walk + setback + depth / 2);
      add_box(scene, material, {x, y + width / 2, height / 2}, {depth / 2, width / 2, height / 2});
      y += width + (rng.chance(0.3) ? rng.uniform(2, 6) : 0.0);
    }
  }

  // Poles and trees along the kerbs (never right at the camera).
  const int metal =
      add_material(scene, Pattern::kNoise, {0.35, 0.36, 0.38}, {0.25, 0.26, 0.28}, 0.5);
  const int bark = add_material(scene, Pattern::kNoise, {0.35, 0.25, 0.15}, {0.2, 0.15, 0.1}, 0.3);
  const int leaves = add_material(
      scene, Pattern::kNoise, jitter_color(rng, {0.22, 0.42, 0.12}, 0.2), {0.1, 0.22, 0.06}, 0.5);
  for (double side : {-1.0, 1.0}) {
    const double x = side * (road + 0.5);
    for (double y = -80 + rng.uniform(0, 10); y < 80; y += rng.uniform(10, 22)) {
      if (std::hypot(x - cam_x, y - cam_y) < 2.0) continue;
      if (rng.chance(0.5)) {
        const double h = rng.uniform(4.5, 7.5);
        add_cylinder(scene, metal, {x, y, h / 2}, {0, 0, 1}, 0.08, h / 2);
        if (rng.chance(0.6)) add_box(scene, metal, {x - side * 0.6, y, h}, {0.6, 0.12, 0.06});
      } else {
        const double trunk = rng.uniform(1.5, 3.0), crown = rng.uniform(1.2, 2.5);
        add_cylinder(scene, bark, {x, y, trunk / 2}, {0, 0, 1}, 0.12, trunk / 2);
        add_sphere(scene, leaves, {x, y, trunk + crown * 0.8}, crown);
      }
    }
  }

  // Parked cars along both kerbs.
  const int glass =
      add_material(scene, Pattern::kNoise, {0.15, 0.18, 0.22}, {0.05, 0.07, 0.1}, 0.5);
  const int tyre =
      add_material(scene, Pattern::kNoise, {0.08, 0.08, 0.08}, {0.04, 0.04, 0.04}, 0.2);
  static const Vec3 paints[] = {{0.7, 0.1, 0.1}, {0.1, 0.2, 0.5},  {0.85, 0.85, 0.85},
                                {0.1, 0.1, 0.1}, {0.5, 0.5, 0.52}, {0.2, 0.4, 0.25}};
  for (double side : {-1.0, 1.0}) {
    const double x = side * (road - 1.1);
    for (double y = -60 + rng.uniform(0, 8); y < 60; y += rng.uniform(5.5, 14)) {
      if (std::abs(x - cam_x) < 2.2 && std::abs(y - cam_y) < 3.5) continue;
      if (rng.chance(0.3)) continue;
      const Vec3 second = jitter_color(rng, paints[rng.integer(0, 5)], 0.1);
      const Vec3 first = jitter_color(rng, paints[rng.integer(0, 5)], 0.1);
      const int paint = add_material(scene, Pattern::kNoise, first, second, 3.0);
      add_car(scene, rng, x, y, paint, glass, tyre);
    }
  }

  const double azimuth = rng.uniform(-kPi, kPi), elevation = rng.uniform(0.3, 1.1);
  Light sun;
  sun.directional = true;
  sun.position = {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                  std::sin(elevation)};
  const double power = rng.uniform(0.8, 1.1);
  sun.color = {power, power * 0.95, power * 0.85};
  scene.lights.push_back(sun);
  scene.ambient = jitter_color(rng, {0.3, 0.33, 0.38}, 0.15);
  return scene;
}

}  // namespace omnipoint::data::synth
