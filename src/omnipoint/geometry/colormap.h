#pragma once
// Colour maps for visualisations (depth_vis.png and friends): the Turbo and Viridis maps
// sampled at 33 points and interpolated linearly (within 3/255 of OpenCV's COLORMAP_TURBO
// and COLORMAP_VIRIDIS, checked by the tests).
#include <ATen/core/Tensor.h>

namespace omnipoint::geometry {

enum class Colormap { Turbo, Viridis };

// Maps values (...) linearly from [low, high] (clamped) to RGB (..., 3) in [0, 1], in the
// values' floating dtype (float32 for integer input). Pixels outside `valid` (..., bool)
// and non-finite values are black.
at::Tensor apply_colormap(const at::Tensor& values, double low, double high,
                          Colormap map = Colormap::Turbo, const at::Tensor& valid = {});

// Colours depth maps (..., H, W) by inverse depth (near = warm with Turbo), each map
// stretched between its own nearest and farthest valid pixel. Valid: `valid` (when given)
// and finite depth > 0; other pixels are black. Returns (..., H, W, 3) in [0, 1].
at::Tensor colorize_depth(const at::Tensor& depth, const at::Tensor& valid = {},
                          Colormap map = Colormap::Turbo);

}  // namespace omnipoint::geometry
