#include "omnipoint/data/transform.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "omnipoint/geometry/sparse_sampling.h"

namespace omnipoint::data {

Sample crop_sample(const Sample& s, int64_t x0, int64_t y0, int64_t width, int64_t height) {
  if (x0 < 0 || y0 < 0 || width < 1 || height < 1 || x0 + width > s.camera.width() ||
      y0 + height > s.camera.height())
    throw std::invalid_argument("crop window " + std::to_string(width) + "x" +
                                std::to_string(height) + "+" + std::to_string(x0) + "+" +
                                std::to_string(y0) + " does not fit the image " +
                                s.camera.to_spec());
  const auto window = [&](const at::Tensor& t) {
    return t.narrow(0, y0, height).narrow(1, x0, width).contiguous();
  };
  Sample cropped = s;  // the other fields (pose, label kind) carry over
  cropped.camera = s.camera.cropped(x0, y0, width, height);
  cropped.image = window(s.image);
  cropped.distance = window(s.distance);
  cropped.mask = window(s.mask);
  return cropped;
}

Sample resize_sample(const Sample& s, int64_t width, int64_t height) {
  if (width < 1 || height < 1)
    throw std::invalid_argument("resize to " + std::to_string(width) + "x" +
                                std::to_string(height) + ": expected a positive size");
  const auto chw = s.image.permute({2, 0, 1}).unsqueeze(0);
  const bool shrinking = width < s.camera.width() || height < s.camera.height();
  const auto image = shrinking ? at::adaptive_avg_pool2d(chw, {height, width})
                               : at::upsample_bilinear2d(chw, {height, width}, false);
  // Nearest neighbour at the new pixel centres: source index floor((i + 0.5) * W / W').
  const auto pick = [](int64_t from, int64_t to, const at::TensorOptions& options) {
    return at::floor((at::arange(to, options.dtype(at::kDouble)) + 0.5) * (double(from) / to))
        .clamp_max(from - 1)
        .to(at::kLong);
  };
  const auto rows = pick(s.camera.height(), height, s.distance.options());
  const auto cols = pick(s.camera.width(), width, s.distance.options());
  const auto nearest = [&](const at::Tensor& t) {
    return t.index_select(0, rows).index_select(1, cols).contiguous();
  };
  Sample resized = s;  // the other fields (pose, label kind) carry over
  resized.camera = s.camera.resized(width, height);
  resized.image = image.squeeze(0).permute({1, 2, 0}).contiguous();
  if (s.sparse_labels) {
    // Nearest-neighbour picking would keep about one sample in (W·H)/(W'·H') when shrinking:
    // each sample moves to the new pixel holding its pixel centre instead (nearest one wins).
    resized.distance = geometry::resize_sparse_map(
                           at::where(s.mask, s.distance, at::zeros_like(s.distance)), width, height)
                           .contiguous();
    resized.mask = resized.distance > 0;
  } else {
    resized.distance = nearest(s.distance);
    resized.mask = nearest(s.mask);
  }
  return resized;
}

Sample fit_sample(const Sample& sample, int64_t width, int64_t height) {
  const int64_t w = sample.camera.width(), h = sample.camera.height();
  if (w == width && h == height) return sample;
  int64_t crop_w = w, crop_h = h;
  if (w * height > h * width)
    crop_w = std::max<int64_t>(1, h * width / height);
  else
    crop_h = std::max<int64_t>(1, w * height / width);
  return resize_sample(crop_sample(sample, (w - crop_w) / 2, (h - crop_h) / 2, crop_w, crop_h),
                       width, height);
}

}  // namespace omnipoint::data
