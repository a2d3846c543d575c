#pragma once
// Procedural textures as batched tensor code. Noise comes from an integer hash of lattice
// coordinates (exact int64 arithmetic), so textures are identical on every device.
#include <ATen/core/Tensor.h>

#include <cstdint>

#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {

// Hash of integer lattice coordinates (int64 tensors, broadcastable) to floats in [0, 1)
// with the dtype/device of `like`.
at::Tensor lattice_hash(const at::Tensor& ix, const at::Tensor& iy, std::uint32_t seed,
                        const at::Tensor& like);
// Smooth value noise in [0, 1) at continuous coordinates (u, v).
at::Tensor value_noise(const at::Tensor& u, const at::Tensor& v, std::uint32_t seed);
// Fractal sum of `octaves` value-noise octaves, normalised to [0, 1).
at::Tensor fractal_noise(const at::Tensor& u, const at::Tensor& v, std::uint32_t seed, int octaves);

// Surface albedo (N, 3) in [0, 1] for per-pixel material indices (N) and texture
// coordinates in metres (N, 2).
at::Tensor albedo(const Scene& scene, const at::Tensor& material, const at::Tensor& uv);

}  // namespace omnipoint::data::synth
