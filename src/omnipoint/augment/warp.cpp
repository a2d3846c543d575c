#include "omnipoint/augment/warp.h"
#include "omnipoint/util/threads.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace omnipoint::augment {

at::Tensor rotation_from_angles(double yaw_deg, double pitch_deg, double roll_deg) {
  const double deg = M_PI / 180.0;
  const double cy = std::cos(yaw_deg * deg), sy = std::sin(yaw_deg * deg);
  const double cp = std::cos(pitch_deg * deg), sp = std::sin(pitch_deg * deg);
  const double cr = std::cos(roll_deg * deg), sr = std::sin(roll_deg * deg);
  const auto opts = at::TensorOptions().dtype(at::kDouble);
  const at::Tensor ry = at::tensor({cy, 0.0, sy, 0.0, 1.0, 0.0, -sy, 0.0, cy}, opts).view({3, 3});
  // Pitch turns +z towards −y (up): column 3 of Rx is (0, −sin, cos).
  const at::Tensor rx = at::tensor({1.0, 0.0, 0.0, 0.0, cp, -sp, 0.0, sp, cp}, opts).view({3, 3});
  const at::Tensor rz = at::tensor({cr, -sr, 0.0, sr, cr, 0.0, 0.0, 0.0, 1.0}, opts).view({3, 3});
  return ry.matmul(rx).matmul(rz);
}

namespace {

// The bilinear cell of a position (x, y) in [0, W] x [0, H] (pixel centres at i + 0.5),
// clamped to the outermost pixel centres: its four pixels (row-major indices, in the order
// top-left, top-right, bottom-left, bottom-right) and their weights. The one rule of both
// samplers below.
template <typename T>
struct BilinearCell {
  std::array<int64_t, 4> pixel;
  std::array<T, 4> weight;
};
template <typename T>
BilinearCell<T> bilinear_cell(T x, T y, int64_t width, int64_t height) {
  const T gx = std::clamp<T>(x - T(0.5), 0, width - 1);
  const T gy = std::clamp<T>(y - T(0.5), 0, height - 1);
  const int64_t c0 = std::min<int64_t>(static_cast<int64_t>(gx), std::max<int64_t>(width - 2, 0));
  const int64_t r0 = std::min<int64_t>(static_cast<int64_t>(gy), std::max<int64_t>(height - 2, 0));
  const T fx = std::clamp<T>(gx - c0, 0, 1), fy = std::clamp<T>(gy - r0, 0, 1);
  const int64_t c1 = std::min(c0 + 1, width - 1), r1 = std::min(r0 + 1, height - 1);
  return {{r0 * width + c0, r0 * width + c1, r1 * width + c0, r1 * width + c1},
          {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy}};
}

}  // namespace

SampledDistance sample_distance(const at::Tensor& distance, const at::Tensor& valid,
                                const at::Tensor& pixels, double tolerance) {
  if (!distance.defined() || distance.dim() != 2 || !valid.defined() ||
      valid.sizes() != distance.sizes() || valid.scalar_type() != at::kBool) {
    throw std::invalid_argument(
        "sample_distance: expected a distance map (H, W) and a bool valid map (H, W)");
  }
  if (!pixels.defined() || pixels.size(-1) != 2)
    throw std::invalid_argument("sample_distance: pixels must be (..., 2)");
  const int64_t height = distance.size(0), width = distance.size(1);
  // One pass per sample on the CPU (the same rule as tensor operations took ~0.5 s for a
  // million samples here, most of it in temporaries); other devices' tensors come back there.
  const at::Tensor map = distance.to(at::kCPU).contiguous();
  const at::Tensor labelled = valid.to(at::kCPU).contiguous();
  const at::Tensor p = pixels.to(map.options()).contiguous();
  const auto lead = pixels.sizes().slice(0, pixels.dim() - 1);
  at::Tensor value = at::empty(lead, map.options());
  at::Tensor ok = at::empty(lead, labelled.options());
  const int64_t count = value.numel();
  AT_DISPATCH_FLOATING_TYPES(map.scalar_type(), "sample_distance", [&] {
    const scalar_t* d = map.data_ptr<scalar_t>();
    const bool* v = labelled.data_ptr<bool>();
    const scalar_t* xy = p.data_ptr<scalar_t>();
    scalar_t* out = value.data_ptr<scalar_t>();
    bool* out_ok = ok.data_ptr<bool>();
    util::parallel_for(0, count, 16384, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) {
        const scalar_t x = xy[2 * i], y = xy[2 * i + 1];
        out[i] = 0;
        out_ok[i] = false;
        if (!(x >= 0 && x <= width && y >= 0 && y <= height)) continue;  // NaN fails too
        const BilinearCell<scalar_t> cell = bilinear_cell(x, y, width, height);
        // Corners with zero weight still take part in the agreement test: a sample next to
        // an edge is not trusted either way.
        scalar_t low = std::numeric_limits<scalar_t>::infinity(), high = 0;
        bool usable = true;
        for (const int64_t k : cell.pixel) {
          usable = usable && v[k] && std::isfinite(d[k]) && d[k] > 0;
          low = std::min(low, d[k]);
          high = std::max(high, d[k]);
        }
        if (!usable || !(high <= low * (1 + static_cast<scalar_t>(tolerance)))) continue;
        out[i] = cell.weight[0] * d[cell.pixel[0]] + cell.weight[1] * d[cell.pixel[1]] +
                 cell.weight[2] * d[cell.pixel[2]] + cell.weight[3] * d[cell.pixel[3]];
        out_ok[i] = true;
      }
    });
  });
  return {value.to(distance.device()), ok.to(distance.device())};
}

at::Tensor sample_image(const at::Tensor& image, const at::Tensor& pixels) {
  if (!image.defined() || image.dim() != 3 || !at::isFloatingType(image.scalar_type()))
    throw std::invalid_argument("sample_image: expected a floating image (H, W, C)");
  if (!pixels.defined() || pixels.size(-1) != 2)
    throw std::invalid_argument("sample_image: pixels must be (..., 2)");
  const int64_t height = image.size(0), width = image.size(1), channels = image.size(2);
  // One pass per sample over the (H, W, C) layout, on the CPU like sample_distance (grid_sample
  // wanted a channels-first copy of the image and normalised coordinates: ~30 ms for two
  // million samples of a 1 MP image here).
  const at::Tensor colours = image.to(at::kCPU).contiguous();
  const at::Tensor p = pixels.to(colours.options()).contiguous();
  std::vector<int64_t> shape(pixels.sizes().begin(), pixels.sizes().end() - 1);
  shape.push_back(channels);
  at::Tensor out = at::empty(shape, colours.options());
  const int64_t count = p.numel() / 2;
  if (height == 0 || width == 0 || count == 0) return out.zero_().to(image.device());
  AT_DISPATCH_FLOATING_TYPES(colours.scalar_type(), "sample_image", [&] {
    const scalar_t* c = colours.data_ptr<scalar_t>();
    const scalar_t* xy = p.data_ptr<scalar_t>();
    scalar_t* o = out.data_ptr<scalar_t>();
    util::parallel_for(0, count, 16384, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) {
        // Border padding: every position clamps to the outermost pixel centres; NaN samples
        // the first pixel (a NaN would survive the clamp).
        const scalar_t x = std::isnan(xy[2 * i]) ? 0 : xy[2 * i];
        const scalar_t y = std::isnan(xy[2 * i + 1]) ? 0 : xy[2 * i + 1];
        const BilinearCell<scalar_t> cell = bilinear_cell(x, y, width, height);
        const scalar_t* p00 = c + cell.pixel[0] * channels;
        const scalar_t* p01 = c + cell.pixel[1] * channels;
        const scalar_t* p10 = c + cell.pixel[2] * channels;
        const scalar_t* p11 = c + cell.pixel[3] * channels;
        for (int64_t k = 0; k < channels; ++k)
          o[i * channels + k] = cell.weight[0] * p00[k] + cell.weight[1] * p01[k] +
                                cell.weight[2] * p10[k] + cell.weight[3] * p11[k];
      }
    });
  });
  return out.to(image.device());
}

}  // namespace omnipoint::augment
