#pragma once
// A point map seen as a surface over its pixel grid: the pixels at depth discontinuities
// ("flying pixels", which interpolate between a foreground and a background) and the grid
// triangulation of the rest (predict's edge filter and mesh.glb).
#include <ATen/core/Tensor.h>

namespace omnipoint::geometry {

// MoGe's depth edge (utils3d depth_map_edge with rtol): a valid pixel whose 3x3 neighbourhood
// of valid pixels spans more than rtol times its own value, max - min > rtol · d. Taken on
// radial distance (...) rather than planar depth, so that wide lenses and panoramas, where
// planar depth is <= 0, are filtered too. Invalid pixels (outside `mask` (...) bool when
// given, non-finite or <= 0) neither are edges nor make one. rtol <= 0: no edges (off).
// Returns (...) bool.
at::Tensor depth_edge_mask(const at::Tensor& distance, const at::Tensor& mask, double rtol);

struct GridMesh {
  at::Tensor vertices;  // (N, 3) the points of the pixels some triangle uses, row-major order
  at::Tensor pixels;    // (N) int64 row-major pixel index of each vertex (for colours etc.)
  at::Tensor faces;     // (T, 3) int32 vertex indices
};
// Two triangles per 2x2 cell of pixels that are all in `mask` (H, W) bool, from points
// (H, W, 3). Winding: counter-clockwise as seen from the camera (the image's orientation), so
// the faces' normals point towards it. Cells with an invalid corner (e.g. a removed depth
// edge) are skipped.
GridMesh grid_mesh(const at::Tensor& points, const at::Tensor& mask);

}  // namespace omnipoint::geometry
