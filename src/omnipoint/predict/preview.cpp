#include "omnipoint/predict/preview.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace omnipoint::predict {

namespace {

constexpr uint8_t kBackground = 40;
constexpr int64_t kPixelStride = int64_t{1} << 31;  // z-buffer keys: pixel · 2³¹ + distance rank

// Rotation about y (yaw) then about x (pitch), as a (3, 3) float64 matrix.
at::Tensor orbit_rotation(double yaw_deg, double pitch_deg) {
  const double a = yaw_deg * M_PI / 180.0, b = pitch_deg * M_PI / 180.0;
  const at::Tensor yaw =
      at::tensor({std::cos(a), 0.0, -std::sin(a), 0.0, 1.0, 0.0, std::sin(a), 0.0, std::cos(a)},
                 at::kDouble)
          .view({3, 3});
  // Pitch looks down from above: our y axis points down, so the camera rises towards -y.
  const at::Tensor pitch =
      at::tensor({1.0, 0.0, 0.0, 0.0, std::cos(b), std::sin(b), 0.0, -std::sin(b), std::cos(b)},
                 at::kDouble)
          .view({3, 3});
  return pitch.matmul(yaw);
}

double quantile_of(const at::Tensor& values, double q) {
  return at::quantile(values, q).item<double>();
}

}  // namespace

at::Tensor render_preview(const at::Tensor& points, const at::Tensor& colors,
                          const PreviewOptions& options) {
  if (points.dim() != 2 || points.size(1) != 3 || colors.sizes() != points.sizes() ||
      colors.scalar_type() != at::kByte)
    throw std::invalid_argument("preview: expected points (N, 3) and uint8 colors (N, 3)");
  const int64_t width = options.width, height = options.height;
  at::Tensor image = at::full({height, width, 3}, kBackground, at::kByte);
  if (points.size(0) == 0) return image;

  const int64_t keep_every =
      std::max<int64_t>(1, (points.size(0) + options.max_points - 1) / options.max_points);
  const at::Tensor p = points.slice(0, 0, points.size(0), keep_every).to(at::kCPU, at::kDouble);
  const at::Tensor kept_colors = colors.slice(0, 0, colors.size(0), keep_every);
  // Subsample further for the quantiles (at::quantile has an input size limit).
  const int64_t stride = std::max<int64_t>(1, p.size(0) / 100000);
  const at::Tensor sample = p.slice(0, 0, p.size(0), stride);
  const at::Tensor centre = std::get<0>(sample.median(0));
  at::Tensor view = (p - centre).matmul(orbit_rotation(options.yaw_deg, options.pitch_deg).t());
  // Step back: the nearest 2 % of the cloud ends up at a distance of a quarter of its extent.
  const at::Tensor sample_view = view.slice(0, 0, view.size(0), stride);
  const double extent = quantile_of(sample_view.norm(2, 1), 0.98);
  const double back = std::max(0.0, 0.25 * extent - quantile_of(sample_view.select(1, 2), 0.02));
  view.select(1, 2).add_(back);

  const at::Tensor z = view.select(1, 2);
  const at::Tensor in_front = z > 1e-3 * std::max(extent, 1e-9);
  const at::Tensor safe_z = at::where(in_front, z, at::ones_like(z));
  const at::Tensor u = view.select(1, 0) / safe_z, v = view.select(1, 1) / safe_z;
  const at::Tensor u_front = u.masked_select(in_front), v_front = v.masked_select(in_front);
  if (u_front.numel() == 0) return image;
  const at::Tensor u_sample =
      u_front.slice(0, 0, u_front.numel(), std::max<int64_t>(1, u_front.numel() / 100000));
  const at::Tensor v_sample =
      v_front.slice(0, 0, v_front.numel(), std::max<int64_t>(1, v_front.numel() / 100000));
  const double u0 = quantile_of(u_sample, 0.01), u1 = quantile_of(u_sample, 0.99);
  const double v0 = quantile_of(v_sample, 0.01), v1 = quantile_of(v_sample, 0.99);
  // One focal for both axes (square pixels), framing the central 98 % with a 5 % margin.
  const double focal =
      0.9 * std::min(width / std::max(u1 - u0, 1e-9), height / std::max(v1 - v0, 1e-9));
  const at::Tensor x = (u - 0.5 * (u0 + u1)) * focal + 0.5 * width;
  const at::Tensor y = (v - 0.5 * (v0 + v1)) * focal + 0.5 * height;

  // Splat squares sized so that the visible points roughly cover their image area at the
  // median distance, growing towards the viewer (nearer points are magnified more).
  const int64_t visible = in_front.sum().item<int64_t>();
  const double base = std::sqrt(0.5 * static_cast<double>(width * height) / visible);
  const double z_median = quantile_of(sample_view.select(1, 2), 0.5);
  const at::Tensor size = (base * z_median / safe_z).ceil().clamp(1, 6);
  const int64_t largest = static_cast<int64_t>(size.max().item<double>());
  // Z-buffer by one sort: key = pixel · 2³¹ + quantised distance, the first key of each pixel
  // wins (scatter_reduce's amin is far slower on the CPU for millions of splats).
  const at::Tensor z_front = z.masked_select(in_front);
  const double z_low = z_front.min().item<double>(),
               z_span = std::max(z_front.max().item<double>() - z_low, 1e-12);
  const at::Tensor z_rank =
      ((z - z_low) / z_span * 2147483646.0).clamp(0, 2147483646.0).to(at::kLong);
  std::vector<at::Tensor> keys, sources;
  const at::Tensor index = at::arange(p.size(0), at::kLong);
  for (int64_t dy = 0; dy < largest; ++dy) {
    for (int64_t dx = 0; dx < largest; ++dx) {
      const at::Tensor col = at::floor(x + static_cast<double>(dx)),
                       row = at::floor(y + static_cast<double>(dy));
      const at::Tensor keep = in_front & (size > static_cast<double>(std::max(dx, dy))) &
                              (col >= 0) & (col < width) & (row >= 0) & (row < height);
      const at::Tensor pixel = row.to(at::kLong) * width + col.to(at::kLong);
      keys.push_back((pixel * kPixelStride + z_rank).masked_select(keep));
      sources.push_back(index.masked_select(keep));
    }
  }
  const auto [sorted, order] = at::cat(keys).sort();
  const at::Tensor pixel_of = at::floor_divide(sorted, kPixelStride);
  const at::Tensor first = at::ones_like(pixel_of, at::kBool);
  if (pixel_of.numel() > 1)
    first.slice(0, 1).copy_(pixel_of.slice(0, 1) != pixel_of.slice(0, 0, -1));
  const at::Tensor winner_pixel = pixel_of.masked_select(first);
  const at::Tensor winner_point = at::cat(sources).index_select(0, order.masked_select(first));

  // Dim with distance: the nearest points at full brightness, the farthest at 45 %.
  const double z_near =
      quantile_of(sample_view.select(1, 2), 0.02);  // sample_view shares the shifted z
  const double z_far = std::max(quantile_of(sample_view.select(1, 2), 0.98), z_near + 1e-9);
  const at::Tensor shade = 1.0 - 0.55 * ((z - z_near) / (z_far - z_near)).clamp(0.0, 1.0);
  const at::Tensor shaded = (kept_colors.to(at::kCPU, at::kDouble) * shade.unsqueeze(1))
                                .round()
                                .clamp(0, 255)
                                .to(at::kByte);
  image.view({height * width, 3})
      .index_copy_(0, winner_pixel, shaded.index_select(0, winner_point));
  return image;
}

}  // namespace omnipoint::predict
