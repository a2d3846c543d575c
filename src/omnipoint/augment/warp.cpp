#include "omnipoint/augment/warp.h"

#include <ATen/ATen.h>

#include <cmath>
#include <stdexcept>

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
  const at::Tensor p = pixels.to(distance.scalar_type());
  const at::Tensor x = p.select(-1, 0), y = p.select(-1, 1);
  const at::Tensor inside = (x >= 0) & (x <= width) & (y >= 0) & (y <= height);
  const at::Tensor gx = (x - 0.5).clamp(0, width - 1), gy = (y - 0.5).clamp(0, height - 1);
  const at::Tensor x0 = gx.floor().clamp(0, std::max<int64_t>(width - 2, 0)),
                   y0 = gy.floor().clamp(0, std::max<int64_t>(height - 2, 0));
  const at::Tensor fx = (gx - x0).clamp(0, 1), fy = (gy - y0).clamp(0, 1);
  const at::Tensor c0 = x0.to(at::kLong), r0 = y0.to(at::kLong);
  const at::Tensor c1 = (c0 + 1).clamp_max(width - 1), r1 = (r0 + 1).clamp_max(height - 1);
  const at::Tensor flat_d = distance.reshape(-1), flat_v = valid.reshape(-1);
  auto corner = [&](const at::Tensor& r, const at::Tensor& c) { return r * width + c; };
  const at::Tensor idx =
      at::stack({corner(r0, c0), corner(r0, c1), corner(r1, c0), corner(r1, c1)}, -1);
  const at::Tensor d = flat_d.index({idx});
  const at::Tensor v = flat_v.index({idx});
  const at::Tensor w = at::stack({(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy}, -1);
  // Corners with zero weight still take part in the agreement test: a sample next to an
  // edge is not trusted either way.
  const at::Tensor all_valid = v.all(-1) & at::isfinite(d).all(-1) & (d > 0).all(-1);
  const at::Tensor dmax = std::get<0>(d.max(-1)), dmin = std::get<0>(d.min(-1));
  const at::Tensor ok = inside & all_valid & (dmax <= dmin * (1.0 + tolerance));
  const at::Tensor value = (w * d).sum(-1);
  return {at::where(ok, value, at::zeros_like(value)), ok};
}

at::Tensor sample_image(const at::Tensor& image, const at::Tensor& pixels) {
  if (!image.defined() || image.dim() != 3)
    throw std::invalid_argument("sample_image: expected an image (H, W, C)");
  const int64_t height = image.size(0), width = image.size(1);
  const auto lead = pixels.sizes().slice(0, pixels.dim() - 1);
  const at::Tensor p = pixels.to(image.scalar_type()).reshape({1, 1, -1, 2});
  const at::Tensor grid = at::stack(
      {p.select(-1, 0) * (2.0 / width) - 1.0, p.select(-1, 1) * (2.0 / height) - 1.0}, -1);
  const at::Tensor input = image.permute({2, 0, 1}).unsqueeze(0);
  const at::Tensor out =
      at::grid_sampler_2d(input, grid, /*bilinear*/ 0, /*border*/ 1, /*align_corners*/ false);
  std::vector<int64_t> shape(lead.begin(), lead.end());
  shape.push_back(image.size(2));
  return out.squeeze(0).squeeze(1).transpose(0, 1).reshape(shape);
}

}  // namespace omnipoint::augment
