#pragma once
// Ray/distance geometry (docs/DESIGN.md): every pixel has a unit ray r and a radial distance d,
// the point is P = d · r, planar depth is derived (z = P.z, may be <= 0 for wide-FoV
// cameras). Camera frame: x right, y down, z forward; metres.
//
// Shapes: rays and points (..., 3), distances and depths (...), point maps (..., H, W, 3)
// with masks (..., H, W); leading dimensions are batch dimensions. Any floating dtype and
// device; outputs take the inputs' dtype and device. Invalid entries are zero, never NaN.
#include <ATen/core/Tensor.h>

namespace omnipoint::geometry {

// P = d · r, broadcasting distance (...) against rays (..., 3).
at::Tensor points_from_rays(const at::Tensor& rays, const at::Tensor& distance);

struct RaysAndDistance {
  at::Tensor rays;      // (..., 3) unit rays; zero where invalid
  at::Tensor distance;  // (...)    |P|; zero where invalid
  at::Tensor valid;     // (...)    bool: |P| > 0 and finite
};
// Splits points (..., 3) into unit rays and radial distances.
RaysAndDistance rays_from_points(const at::Tensor& points);

// Planar depth z = P.z of points (..., 3); negative behind the camera.
at::Tensor planar_depth(const at::Tensor& points);

struct DistanceFromDepth {
  at::Tensor distance;  // (...) d = z / r_z; zero where invalid
  at::Tensor valid;     // (...) bool: r_z > 0, z > 0 and finite
};
// Radial distance from planar depth z (...) along unit rays (..., 3). Only rays with a
// forward component carry planar depth (z = d · r_z with d > 0 needs r_z > 0 and z > 0);
// every other pixel is invalid.
DistanceFromDepth distance_from_planar_depth(const at::Tensor& depth, const at::Tensor& rays);

struct Normals {
  at::Tensor normals;  // (..., H, W, 3) unit normals facing the camera; zero where invalid
  at::Tensor valid;    // (..., H, W) bool
};
// Normals of a point map (..., H, W, 3), as MoGe does: the cross products of the
// differences to the four neighbours (up/left, left/down, down/right, right/up), each
// used when the pixel and both neighbours are valid, summed and normalised. Oriented so
// that n · P <= 0 (facing the camera). `valid` (..., H, W) defaults to the finite pixels.
Normals normals_from_point_map(const at::Tensor& points, const at::Tensor& valid = {});

struct PointCloud {
  at::Tensor points;  // (..., N, 3) in the point map's dtype
  at::Tensor colors;  // (..., N, 3) uint8 RGB
  at::Tensor valid;   // (..., N) bool
};
// Flattens a point map (..., H, W, 3), an image (..., H, W, 3) RGB in [0, 1] (any floating
// dtype; or uint8) and a mask (..., H, W) into a point cloud of N = H·W points. Points are
// valid where the mask is set (all pixels when undefined) and finite.
PointCloud make_point_cloud(const at::Tensor& point_map, const at::Tensor& image,
                            const at::Tensor& mask = {});
// The valid points of an unbatched cloud (N, 3) only.
PointCloud valid_points(const PointCloud& cloud);

}  // namespace omnipoint::geometry
