#include "omnipoint/geometry/grid_surface.h"

#include <ATen/ATen.h>

#include <limits>
#include <stdexcept>

namespace omnipoint::geometry {

at::Tensor depth_edge_mask(const at::Tensor& distance, const at::Tensor& mask, double rtol) {
  if (!distance.defined() || distance.dim() < 2 || !at::isFloatingType(distance.scalar_type()))
    throw std::invalid_argument("depth_edge_mask: distance must be a floating tensor (..., H, W)");
  if (mask.defined() && (mask.scalar_type() != at::kBool || mask.sizes() != distance.sizes()))
    throw std::invalid_argument("depth_edge_mask: mask must be a bool tensor like the distance");
  at::Tensor valid = at::isfinite(distance) & (distance > 0);
  if (mask.defined()) valid = valid & mask;
  if (rtol <= 0) return at::zeros_like(valid);
  const int64_t height = distance.size(-2), width = distance.size(-1);
  // Pooling over (B, 1, H, W); -inf for invalid pixels keeps them out of both extremes (max
  // pooling pads with -inf too, so the image border is no edge).
  const at::Tensor ok = valid.reshape({-1, 1, height, width});
  const at::Tensor d = distance.reshape({-1, 1, height, width});
  const at::Tensor excluded = at::full({}, -std::numeric_limits<double>::infinity(), d.options());
  const at::Tensor high = at::max_pool2d(at::where(ok, d, excluded), {3, 3}, {1, 1}, {1, 1});
  const at::Tensor low = -at::max_pool2d(at::where(ok, -d, excluded), {3, 3}, {1, 1}, {1, 1});
  return (ok & (high - low > rtol * d)).reshape(distance.sizes());
}

GridMesh grid_mesh(const at::Tensor& points, const at::Tensor& mask) {
  if (!points.defined() || points.dim() != 3 || points.size(2) != 3 ||
      !at::isFloatingType(points.scalar_type()))
    throw std::invalid_argument("grid_mesh: points must be a floating tensor (H, W, 3)");
  const int64_t height = points.size(0), width = points.size(1);
  if (!mask.defined() || mask.scalar_type() != at::kBool ||
      mask.sizes() != points.sizes().slice(0, 2))
    throw std::invalid_argument("grid_mesh: mask must be a bool tensor (H, W) like the points");
  if (height < 2 || width < 2)
    return {at::zeros({0, 3}, points.options().device(at::kCPU)), at::zeros({0}, at::kLong),
            at::zeros({0, 3}, at::kInt)};
  const at::Tensor valid = mask.to(at::kCPU);
  // A cell (r, c) spans the pixels (r..r+1, c..c+1).
  const int64_t cell_rows = height - 1, cell_cols = width - 1;
  const auto corner = [&](int64_t dy, int64_t dx) {
    return valid.narrow(0, dy, cell_rows).narrow(1, dx, cell_cols);
  };
  const at::Tensor cells = corner(0, 0) & corner(1, 0) & corner(0, 1) & corner(1, 1);
  const at::Tensor cell_index = cells.nonzero();  // (C, 2) row, col
  const at::Tensor top_left = cell_index.select(1, 0) * width + cell_index.select(1, 1);
  const at::Tensor top_right = top_left + 1, bottom_left = top_left + width,
                   bottom_right = bottom_left + 1;
  // (top-left, bottom-left, top-right) and (top-right, bottom-left, bottom-right): both
  // counter-clockwise in the image (y down), i.e. facing the camera.
  const at::Tensor pixel_faces = at::stack({at::stack({top_left, bottom_left, top_right}, 1),
                                            at::stack({top_right, bottom_left, bottom_right}, 1)},
                                           1)
                                     .reshape({-1, 3});
  // Vertices: the pixels of some kept cell (a pixel is a corner of up to four cells).
  const at::Tensor padded = at::constant_pad_nd(cells.to(at::kByte), {1, 1, 1, 1}, 0);
  const auto cell_at = [&](int64_t dy, int64_t dx) {
    return padded.narrow(0, dy, height).narrow(1, dx, width);
  };
  const at::Tensor used =
      (cell_at(0, 0) | cell_at(1, 0) | cell_at(0, 1) | cell_at(1, 1)).to(at::kBool).reshape({-1});
  const at::Tensor pixels = used.nonzero().squeeze(1);
  at::Tensor vertex_of_pixel = at::full({height * width}, -1, at::kLong);
  vertex_of_pixel.index_put_({pixels}, at::arange(pixels.size(0), at::kLong));
  return {points.to(at::kCPU).reshape({-1, 3}).index_select(0, pixels), pixels,
          vertex_of_pixel.index_select(0, pixel_faces.reshape({-1})).reshape({-1, 3}).to(at::kInt)};
}

}  // namespace omnipoint::geometry
