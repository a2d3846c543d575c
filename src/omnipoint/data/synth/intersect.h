#pragma once
// Batched ray casting against a Scene's analytic primitives. Every function works on rays
// of any count N at once, on the device and floating dtype of its inputs; primitives of one
// shape are tested together as an (N, M) problem (slab test for boxes, quadratics for
// spheres and cylinders). Only elementwise IEEE operations (+ - * / sqrt, min/max,
// comparisons) are used, so results do not depend on thread count or chunking.
#include <ATen/core/Tensor.h>

#include <array>
#include <cstdint>
#include <vector>

#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {

// The scene's primitives as tensors on one device/dtype (built once per render).
struct PackedScene {
  at::Tensor shape;      // (P) int64, Shape
  at::Tensor material;   // (P) int64
  at::Tensor center;     // (P, 3)
  at::Tensor half_size;  // (P, 3)
  at::Tensor yaw_cos;    // (P)
  at::Tensor yaw_sin;    // (P)
  at::Tensor axis;       // (P, 3)
  at::Tensor radius;     // (P)
  // CPU copies for choosing candidates: shapes and bounding spheres (planes: unbounded).
  std::vector<Shape> shapes;
  std::vector<Vec3> bound_centers;
  std::vector<double> bound_radii;
  struct PackedOpening {
    int64_t primitive;
    double face;  // the face's local coordinate along opening.axis (side * half size)
    Opening opening;
  };
  std::vector<PackedOpening> openings;
};
PackedScene pack_scene(const Scene& scene, const at::TensorOptions& options);

// Candidate lists: the global indices (ascending) of the primitives a batch of rays may hit,
// by conservative bounding-sphere tests. Culling never changes a result, only the work.
using Candidates = std::vector<int64_t>;
// Rays from `origin` with directions within the cone around unit `axis` whose half angle
// has cosine `cos_half_angle` (any value in [-1, 1]).
Candidates candidates_in_cone(const PackedScene& scene, const Vec3& origin, const Vec3& axis,
                              double cos_half_angle);
// Rays from origins within the ball (`center`, `radius`) to the point `target`, or, if
// `towards_infinity`, along the unit direction `target` without end.
Candidates candidates_near_path(const PackedScene& scene, const Vec3& center, double radius,
                                const Vec3& target, bool towards_infinity);
// Rays from origins within the ball (`center`, `radius`) no longer than `reach`.
Candidates candidates_within(const PackedScene& scene, const Vec3& center, double radius,
                             double reach);

struct Hit {
  at::Tensor t;          // (N) ray parameter of the nearest hit beyond t_min, +inf on a miss
  at::Tensor primitive;  // (N) int64 global primitive index, -1 on a miss
};
// origins: (N, 3) or (1, 3); directions: (N, 3), unit length. Only `candidates` are tested.
Hit nearest_hit(const PackedScene& scene, const Candidates& candidates, const at::Tensor& origins,
                const at::Tensor& directions, double t_min);

struct Surface {
  at::Tensor normal;    // (N, 3) unit, world frame (orientation not yet towards the ray)
  at::Tensor uv;        // (N, 2) texture coordinates in metres
  at::Tensor material;  // (N) int64
};
// Surface attributes at `points` (N, 3) lying on `primitive` (N, values >= 0).
Surface surface_at(const PackedScene& scene, const at::Tensor& points, const at::Tensor& primitive);

}  // namespace omnipoint::data::synth
