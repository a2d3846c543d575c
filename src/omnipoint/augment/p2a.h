#pragma once
// Perspective-to-Any (P2A, paper §3.4): a labelled RGB-D sample from one camera (usually a
// pinhole) rendered into a virtual camera of any model, giving (image, rays, distance, mask)
// for a lens the dataset never had.
//
// How (per sample, float32 or float64; the camera maths runs as tensor operations, the z-buffer,
// the sampling and the hole filling as one parallel pass each on the CPU, where tensors of
// another device are brought and returned):
// 1. Forward splatting: the source is supersampled (s × s sub-pixel rays, each carrying its
//    distance, bilinear within agreeing pixel quads), lifted to 3-D points, moved into the virtual frame
//    (X_virtual = Rᵀ (X_source − c)), projected, and z-buffered per target pixel
//    (geometry::rasterize_nearest: the nearest surface wins), so occluded points never
//    reach the target.
// 2. Read-back: the visible point of each target pixel, taken along that pixel's own ray,
//    is projected into the source; distance (bilinear, only between pixel centres that
//    agree in depth: warp.h) and colour are read there, i.e. from the same source location.
//    With a shared optical centre (c = 0) this is exact: the target ray IS a source ray.
// 3. Validity: a target pixel is labelled only when a point landed on it, its ray lies in
//    the source frustum on a labelled source pixel, the read-back surface is the
//    z-buffered one (|d_readback − d_zbuffer| <= occlusion_margin · d: fails at
//    disocclusions and depth edges), and, where the splats leave gaps, no clearly nearer
//    surface was splatted within a gap's width (fails where a background point won through
//    a gap between a magnified foreground's splats).
// 4. Optional hole filling (z-buffer gaps whose 3×3 neighbours agree in depth) gives the
//    image a colour and a distance there; filled pixels stay out of the mask.
#include <ATen/core/Tensor.h>

#include <cstdint>

#include "omnipoint/camera/camera.h"

namespace omnipoint::augment {

// A virtual camera placed relative to the source camera.
struct VirtualView {
  camera::Camera camera;
  at::Tensor rotation;  // (3, 3) virtual -> source coordinates (warp.h); undefined = identity
  at::Tensor centre;    // (3) the virtual optical centre in the source frame, metres; undefined = 0
};

struct P2AOptions {
  // s: s × s points per source pixel, so a magnifying target has no gaps; 0 picks the
  // smallest s (at most 4) whose points are denser than the target's pixels everywhere.
  int64_t supersample = 0;
  double tolerance = 0.05;  // relative depth agreement of pixels interpolated between
  // Relative depth difference that means "another surface": between the read-back and the
  // z-buffer, and between a pixel and a nearer splat within the width of the gaps that the
  // supersampling leaves (a background point that won through such a gap).
  double occlusion_margin = 0.1;
  bool fill_holes = true;  // colour/distance for agreeing z-buffer gaps (never in the mask)
};

struct P2AResult {
  camera::Camera camera;  // the target camera (spec: camera.to_spec())
  at::Tensor image;       // (H, W, 3) in the source image's dtype; 0 where nothing is known
  at::Tensor rays;        // (H, W, 3) the target camera's unit rays (0 outside its domain)
  at::Tensor distance;    // (H, W) metres along `rays`; 0 outside the mask except filled holes
  at::Tensor mask;        // (H, W) bool: trusted labels
  at::Tensor filled;      // (H, W) bool: hole-filled pixels (not in mask)
};

// image (H, W, 3) float, distance (H, W) radial distance along the source camera's rays
// (use geometry::distance_from_planar_depth for planar depth), mask (H, W) bool. Sizes must
// match the source camera; bad inputs -> std::invalid_argument naming the input.
P2AResult perspective_to_any(const camera::Camera& source, const at::Tensor& image,
                             const at::Tensor& distance, const at::Tensor& mask,
                             const VirtualView& target, const P2AOptions& options = {});

}  // namespace omnipoint::augment
