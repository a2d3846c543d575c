#pragma once
// Photometric augmentation of training images (labels untouched): colour jitter
// (brightness, contrast, saturation), Gaussian blur, additive noise and JPEG artefacts,
// each drawn from a counter-based generator so a (seed, sample) pair always gets the same
// augmentation. Batched tensor code except JPEG (OpenCV, skipped when unavailable).
#include <ATen/core/Tensor.h>

#include <cstdint>

namespace omnipoint::data {

struct PhotometricOptions {
  double brightness = 0.2;         // multiply by 1 +/- up to this
  double contrast = 0.2;           // scale around the mean by 1 +/- up to this
  double saturation = 0.2;         // scale around the grey value by 1 +/- up to this
  double blur_probability = 0.15;  // Gaussian blur with sigma in [0.4, 1.5] pixels
  double noise_probability = 0.2;  // uniform noise with standard deviation up to noise_std
  double noise_std = 0.03;
  double jpeg_probability = 0.2;  // JPEG round trip at quality 40..95
};

// image: (H, W, 3) float RGB in [0, 1]; returns the augmented image, clamped to [0, 1].
at::Tensor photometric_augment(const at::Tensor& image, const PhotometricOptions& options,
                               std::uint64_t seed);

}  // namespace omnipoint::data
