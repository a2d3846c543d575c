#include "omnipoint/data/photometric.h"

#include <ATen/ATen.h>

#include <cmath>

#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/texture.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/jpeg.h"

namespace omnipoint::data {
namespace {

at::Tensor gaussian_blur(const at::Tensor& image, double sigma) {
  const int64_t radius = static_cast<int64_t>(std::ceil(2.5 * sigma));
  auto taps = at::arange(-radius, radius + 1, image.options());
  auto kernel = at::exp(-(taps * taps) / (2 * sigma * sigma));
  kernel = kernel / kernel.sum();
  // Separable, per channel, edges replicated.
  auto x = image.permute({2, 0, 1}).unsqueeze(1);  // (3, 1, H, W)
  x = at::replication_pad2d(x, {radius, radius, radius, radius});
  x = at::conv2d(x, kernel.view({1, 1, 1, -1}));
  x = at::conv2d(x, kernel.view({1, 1, -1, 1}));
  return x.squeeze(1).permute({1, 2, 0});
}

}  // namespace

at::Tensor photometric_augment(const at::Tensor& input, const PhotometricOptions& o,
                               std::uint64_t seed) {
  synth::Random rng(seed, 0x70686f746fULL);
  auto image = input.to(at::kFloat);
  image = image * rng.uniform(1 - o.brightness, 1 + o.brightness);
  const double contrast = rng.uniform(1 - o.contrast, 1 + o.contrast);
  image = (image - image.mean()) * contrast + image.mean();
  const auto grey = (image * at::tensor({0.299, 0.587, 0.114}, image.options())).sum(-1, true);
  image = grey + (image - grey) * rng.uniform(1 - o.saturation, 1 + o.saturation);
  image = image.clamp(0, 1);
  if (rng.chance(o.blur_probability)) image = gaussian_blur(image, rng.uniform(0.4, 1.5));
  if (rng.chance(o.noise_probability)) {
    // Uniform noise from the lattice hash of (pixel, channel): deterministic on any device.
    const double std = rng.uniform(0.0, o.noise_std);
    const auto options = at::TensorOptions().dtype(at::kLong).device(image.device());
    const int64_t h = image.size(0), w = image.size(1);
    const auto rows = at::arange(h, options).view({h, 1, 1}).expand({h, w, 3});
    const auto cells = at::arange(w * 3, options).view({1, w, 3}).expand({h, w, 3});
    const auto u = synth::lattice_hash(rows, cells, rng.seed32(), image);
    image = image + (u - 0.5) * (std * std::sqrt(12.0));
  }
  image = image.clamp(0, 1);
  if (rng.chance(o.jpeg_probability) && io::image_io_available())
    image = io::jpeg_round_trip(image, rng.integer(40, 95));
  return image;
}

}  // namespace omnipoint::data
