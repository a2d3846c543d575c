#pragma once
// Helpers shared by the scene generators (internal to the synth engine).
#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {

// Adds a material and returns its index.
int add_material(Scene& scene, Pattern pattern, const Vec3& a, const Vec3& b, double scale);
// A random colour around `base` (multiplicative jitter per channel, clamped to [0, 1]).
Vec3 jitter_color(Random& rng, const Vec3& base, double amount);
// A random material drawn from a palette suited to furniture / props.
int add_random_prop_material(Scene& scene, Random& rng);

Primitive& add_box(Scene& scene, int material, const Vec3& center, const Vec3& half_size,
                   double yaw = 0.0);
Primitive& add_sphere(Scene& scene, int material, const Vec3& center, double radius);
Primitive& add_cylinder(Scene& scene, int material, const Vec3& center, const Vec3& axis,
                        double radius, double half_length);
Primitive& add_plane(Scene& scene, int material, const Vec3& point, const Vec3& normal);

}  // namespace omnipoint::data::synth

namespace omnipoint::data::synth {

// Interior materials drawn from palettes: a floor, walls and a ceiling.
struct RoomMaterials {
  int floor, walls, ceiling;
};
RoomMaterials add_room_materials(Scene& scene, Random& rng);

// A room centred on the origin: [-hx, hx] x [-hy, hy] x [0, height], walls as a box seen
// from inside, floor and ceiling as slabs (their own materials). Returns the index of the
// wall box, to which openings can be added.
int add_room(Scene& scene, const RoomMaterials& materials, double hx, double hy, double height);

// Random sky colours and cloud cover.
void randomize_sky(Scene& scene, Random& rng);

// Furniture-like props stand on the floor at (x, y); each returns its footprint radius.
double add_table(Scene& scene, Random& rng, double x, double y, double yaw, int material);
double add_chair(Scene& scene, Random& rng, double x, double y, double yaw, int material);

}  // namespace omnipoint::data::synth
