#pragma once
// Renders a Scene through per-pixel camera rays: the renderer never sees a camera model,
// only its ray map, so every model (pinhole, fisheye beyond 180 degrees, panoramas)
// renders exactly. Output conventions:
// - mask: the pixel is valid for the camera AND its ray hits geometry within
//   RenderOptions::max_distance (sky, the far horizon and pixels outside the lens are false).
// - distance: metres along the unit ray to the first surface; depth: the hit's camera-frame
//   z (= distance * ray.z, negative behind the camera); normals: unit, camera frame, facing
//   the camera. All three are 0 where mask is false (never inf or NaN).
// - image: sRGB-like 8-bit RGB; sky pixels show the sky, invalid pixels are black.
#include <ATen/core/Tensor.h>

#include <cstdint>

#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {

struct RenderOptions {
  bool shadows = true;            // shadow rays towards each light that casts shadows
  bool ambient_occlusion = true;  // a few short occlusion rays per pixel
  double max_distance = 1000.0;   // metres; farther hits (the ground plane near the horizon)
                                  // are rendered and labelled as sky
  int64_t tile_size = 128;        // square pixel tiles are the work items (CPU threads take
                                  // tiles; each tile culls the primitives its rays can't reach)
};

struct Render {
  at::Tensor image;     // (H, W, 3) uint8
  at::Tensor distance;  // (H, W) dtype of the rays
  at::Tensor depth;     // (H, W)
  at::Tensor normals;   // (H, W, 3)
  at::Tensor mask;      // (H, W) bool
};

// rays: (H, W, 3) unit camera-frame rays (zero where invalid), float32 or float64, CPU or
// CUDA; valid: (H, W) bool. Rays are placed in the world by scene.pose.
Render render_scene(const Scene& scene, const at::Tensor& rays, const at::Tensor& valid,
                    const RenderOptions& options = {});

}  // namespace omnipoint::data::synth
