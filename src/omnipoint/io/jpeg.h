#pragma once
// JPEG compression artefacts for photometric augmentation: an in-memory encode/decode round
// trip on the optional OpenCV module (image_io_available() in image.h tells whether it is
// there; without it this throws std::runtime_error).
#include <ATen/core/Tensor.h>

namespace omnipoint::io {

// image: (H, W, 3) floating RGB in [0, 1] (any device); quality 1..100. Returns float32 on
// the input's device.
at::Tensor jpeg_round_trip(const at::Tensor& image, int quality);

}  // namespace omnipoint::io
