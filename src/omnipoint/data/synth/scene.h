#pragma once
// A procedural scene: analytic primitives with procedural materials, lights and a camera
// pose, all in metres. Conventions, stated once for the whole engine:
// - World frame: x east, y north, z up (gravity along -z); the ground/floor is z = 0.
// - Camera frame as docs/DESIGN.md: x right, y down, z forward. The pose maps camera to world:
//   X_world = rotation * X_camera + position, rotation = Rz(yaw) * C * Rx(pitch) * Rz(roll)
//   where C maps the level camera looking north (x->east, y->down, z->north). yaw turns
//   counter-clockwise about world z seen from above (0 looks along +y), pitch > 0 looks
//   up, roll turns about the optical axis.
// - A scene and its pose are a pure function of (kind, seed): never of the camera, so one
//   scene renders through several cameras from the same viewpoint.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace omnipoint::data::synth {

using Vec3 = std::array<double, 3>;

enum class SceneKind { kIndoor, kOutdoor, kObject };
// "indoor" | "outdoor" | "object"; anything else -> std::invalid_argument.
SceneKind parse_scene_kind(const std::string& name);
std::string scene_kind_name(SceneKind kind);

// Procedural textures, evaluated in metres on the surface (world-space scale, so texture
// density falls off with distance exactly like a real surface's: a perspective cue).
enum class Pattern : std::int64_t {
  kNoise = 0,    // plaster/asphalt/grass: multi-octave value noise between colours a and b
  kStripes = 1,  // wallpaper/awning: stripes of a and b along u
  kTiles = 2,    // floor/wall tiles of colour a (varied per tile) with grout b
  kBricks = 3,   // running-bond bricks a (varied per brick) with mortar b
  kWood = 4,     // planks along u with a noisy grain between a and b
  kChecker = 5,  // a/b checkerboard
  kFacade = 6,   // building front: wall a with a grid of windows b
};
constexpr int kNumPatterns = 7;

struct Material {
  Pattern pattern = Pattern::kNoise;
  Vec3 color_a{0.5, 0.5, 0.5};  // linear RGB in [0, 1]
  Vec3 color_b{0.3, 0.3, 0.3};
  double scale = 1.0;  // metres per pattern period (tile, brick, stripe pair...)
};

enum class Shape : std::int64_t {
  kPlane = 0,     // infinite plane through `center` with unit normal `axis`
  kBox = 1,       // box: `center`, `half_size`, turned by `yaw` about z, with `openings`;
                  // seen from inside it is a room (walls, floor, ceiling)
  kSphere = 2,    // `center`, `radius`
  kCylinder = 3,  // capped: `center`, unit `axis`, `radius`, half length `half_size[2]`
};
constexpr int kNumShapes = 4;
// Every surface is two-sided: a ray starting inside a box, sphere or cylinder hits its
// inside, so rooms are boxes around the camera.

// A rectangular hole in one face of a box (a door or a window of a room). The face is the
// one whose outward normal is +/- local axis `axis` (sign `side`); the rectangle spans
// [lo, hi] in the face's other two local axes, in increasing axis order, relative to the
// box centre.
struct Opening {
  int axis = 0;
  int side = 1;
  std::array<double, 2> lo{0, 0};
  std::array<double, 2> hi{0, 0};
};

struct Primitive {
  Shape shape = Shape::kBox;
  int material = 0;
  Vec3 center{0, 0, 0};
  Vec3 half_size{0.5, 0.5, 0.5};
  double yaw = 0.0;  // radians
  Vec3 axis{0, 0, 1};
  double radius = 0.5;
  std::vector<Opening> openings;  // kBox only
};

struct Light {
  bool directional = false;  // true: sunlight from direction `position` (unit, towards it)
  Vec3 position{0, 0, 3};
  Vec3 color{1, 1, 1};  // intensity per channel (irradiance for directional lights,
                        // intensity at 1 m for point lights)
  bool casts_shadows = true;
};

struct Pose {
  Vec3 position{0, 0, 1.5};
  double yaw = 0, pitch = 0, roll = 0;  // radians
  // Camera-to-world rotation, row-major; derived from yaw, pitch, roll by make_pose().
  std::array<std::array<double, 3>, 3> rotation{};
};
Pose make_pose(const Vec3& position, double yaw, double pitch, double roll);

struct Sky {
  Vec3 horizon{0.75, 0.82, 0.9};
  Vec3 zenith{0.3, 0.5, 0.85};
  double cloud_cover = 0.4;  // 0 clear .. 1 overcast
  std::uint32_t noise_seed = 0;
};

struct Scene {
  SceneKind kind = SceneKind::kIndoor;
  std::uint64_t seed = 0;
  std::vector<Material> materials;
  std::vector<Primitive> primitives;
  std::vector<Light> lights;
  Vec3 ambient{0.2, 0.2, 0.2};
  double fog_distance = 0;  // > 0: atmospheric perspective, half-way to sky colour at this range
  Sky sky;
  Pose pose;
  std::uint32_t texture_seed = 0;
};

// The procedural generators (one per kind); deterministic in `seed`.
Scene make_indoor_scene(std::uint64_t seed);
Scene make_outdoor_scene(std::uint64_t seed);
Scene make_object_scene(std::uint64_t seed);
Scene make_scene(SceneKind kind, std::uint64_t seed);

}  // namespace omnipoint::data::synth
