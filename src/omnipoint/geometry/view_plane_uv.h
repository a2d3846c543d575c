#pragma once
// MoGe's normalised view-plane coordinates: pixel-centre offsets from the image centre in
// units of the half image diagonal. For an image of aspect a = W/H the image spans
// u ∈ ±a/sqrt(1+a²) (right positive) and v ∈ ±1/sqrt(1+a²) (down positive).
#include <ATen/core/Tensor.h>

#include <cstdint>

namespace omnipoint::geometry {

// (height, width, 2) map of (u, v) at the pixel centres of a width × height grid laid over an
// image of aspect `aspect_ratio` (W/H of the image, not necessarily of the grid). Built with
// linspace in `options`' dtype, exactly as MoGe does (fixtures README §1.4).
at::Tensor normalized_view_plane_uv(int64_t width, int64_t height, double aspect_ratio,
                                    const at::TensorOptions& options);

}  // namespace omnipoint::geometry
