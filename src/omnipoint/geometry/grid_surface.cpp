#include "omnipoint/geometry/grid_surface.h"
#include "omnipoint/util/threads.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

namespace omnipoint::geometry {

at::Tensor depth_edge_mask(const at::Tensor& distance, const at::Tensor& mask, double rtol) {
  if (!distance.defined() || distance.dim() < 2 || !at::isFloatingType(distance.scalar_type()))
    throw std::invalid_argument("depth_edge_mask: distance must be a floating tensor (..., H, W)");
  if (mask.defined() && (mask.scalar_type() != at::kBool || mask.sizes() != distance.sizes()))
    throw std::invalid_argument("depth_edge_mask: mask must be a bool tensor like the distance");
  if (rtol <= 0) return at::zeros(distance.sizes(), distance.options().dtype(at::kBool));
  const at::Tensor given = mask.defined() ? mask.to(at::kCPU).contiguous() : at::Tensor();
  const bool native = distance.scalar_type() == at::kFloat || distance.scalar_type() == at::kDouble;
  const at::Tensor d =
      distance.to(at::kCPU, native ? distance.scalar_type() : at::kFloat).contiguous();
  at::Tensor edges = at::zeros(d.sizes(), d.options().dtype(at::kBool));
  const int64_t height = distance.size(-2), width = distance.size(-1);
  const int64_t rows = d.numel() == 0 ? 0 : d.numel() / width;  // (..., H) map rows
  at::Tensor usable = at::empty(d.sizes(), d.options().dtype(at::kBool));
  AT_DISPATCH_FLOATING_TYPES(d.scalar_type(), "depth_edge_mask", [&] {
    const scalar_t* value = d.data_ptr<scalar_t>();
    const bool* given_ok = given.defined() ? given.data_ptr<bool>() : nullptr;
    bool* ok = usable.data_ptr<bool>();
    for (int64_t i = 0; i < d.numel(); ++i)
      ok[i] = std::isfinite(value[i]) && value[i] > 0 && (given_ok == nullptr || given_ok[i]);
    bool* edge = edges.data_ptr<bool>();
    const auto tolerance = static_cast<scalar_t>(rtol);
    // The extremes of each valid pixel's 3x3 neighbourhood of valid pixels (the map's border
    // clips it), rows in parallel.
    util::parallel_for(
        0, rows, std::max<int64_t>(1, 16384 / width), [&](int64_t begin, int64_t end) {
          for (int64_t row = begin; row < end; ++row) {
            const int64_t y = row % height;
            for (int64_t x = 0; x < width; ++x) {
              const int64_t i = row * width + x;
              if (!ok[i]) continue;
              scalar_t low = value[i], high = value[i];
              for (int64_t dy = y > 0 ? -1 : 0; dy <= (y + 1 < height ? 1 : 0); ++dy)
                for (int64_t dx = x > 0 ? -1 : 0; dx <= (x + 1 < width ? 1 : 0); ++dx) {
                  const int64_t j = i + dy * width + dx;
                  if (!ok[j]) continue;
                  low = std::min(low, value[j]);
                  high = std::max(high, value[j]);
                }
              edge[i] = high - low > tolerance * value[i];
            }
          }
        });
  });
  return edges.to(distance.device());
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
  const at::Tensor valid = mask.to(at::kCPU).contiguous();
  const bool* ok = valid.data_ptr<bool>();
  // A cell (r, c) spans the pixels (r..r+1, c..c+1); kept when all four are valid.
  const int64_t cell_rows = height - 1, cell_cols = width - 1;
  std::vector<uint8_t> kept(static_cast<size_t>(cell_rows * cell_cols));
  int64_t cells = 0;
  for (int64_t r = 0; r < cell_rows; ++r)
    for (int64_t c = 0; c < cell_cols; ++c) {
      const int64_t i = r * width + c;
      const bool all = ok[i] && ok[i + 1] && ok[i + width] && ok[i + width + 1];
      kept[r * cell_cols + c] = all;
      cells += all;
    }
  // Vertices: the pixels of some kept cell (a pixel is a corner of up to four cells), numbered
  // in row-major order.
  const auto cell_kept = [&](int64_t r, int64_t c) {
    return r >= 0 && r < cell_rows && c >= 0 && c < cell_cols && kept[r * cell_cols + c];
  };
  std::vector<int32_t> vertex_of_pixel(static_cast<size_t>(height * width), -1);
  std::vector<int64_t> used;
  for (int64_t y = 0; y < height; ++y)
    for (int64_t x = 0; x < width; ++x)
      if (cell_kept(y - 1, x - 1) || cell_kept(y - 1, x) || cell_kept(y, x - 1) ||
          cell_kept(y, x)) {
        vertex_of_pixel[y * width + x] = static_cast<int32_t>(used.size());
        used.push_back(y * width + x);
      }
  // (top-left, bottom-left, top-right) and (top-right, bottom-left, bottom-right): both
  // counter-clockwise in the image (y down), i.e. facing the camera.
  at::Tensor faces = at::empty({2 * cells, 3}, at::kInt);
  int32_t* face = faces.data_ptr<int32_t>();
  for (int64_t r = 0; r < cell_rows; ++r)
    for (int64_t c = 0; c < cell_cols; ++c) {
      if (!kept[r * cell_cols + c]) continue;
      const int64_t top_left = r * width + c;
      const int32_t tl = vertex_of_pixel[top_left], tr = vertex_of_pixel[top_left + 1],
                    bl = vertex_of_pixel[top_left + width],
                    br = vertex_of_pixel[top_left + width + 1];
      const int32_t triangles[6] = {tl, bl, tr, tr, bl, br};
      std::copy(triangles, triangles + 6, face);
      face += 6;
    }
  const at::Tensor pixels = at::tensor(at::ArrayRef<int64_t>(used.data(), used.size()), at::kLong);
  return {points.to(at::kCPU).reshape({-1, 3}).index_select(0, pixels), pixels, faces};
}

}  // namespace omnipoint::geometry
