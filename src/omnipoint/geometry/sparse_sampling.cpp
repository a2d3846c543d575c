#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/util/threads.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>
#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace omnipoint::geometry {
namespace {

struct Flat {
  at::Tensor values;  // (B, H*W)
  at::Tensor valid;   // (B, H*W) bool
  std::vector<int64_t> shape;
};

Flat flatten_map(const at::Tensor& dense, const at::Tensor& valid, const char* function) {
  if (!dense.defined() || dense.dim() < 2 || !at::isFloatingType(dense.scalar_type())) {
    throw std::invalid_argument(std::string(function) +
                                ": the dense map must be a floating tensor (..., H, W)");
  }
  if (!valid.defined() || valid.scalar_type() != at::kBool || valid.sizes() != dense.sizes()) {
    throw std::invalid_argument(std::string(function) +
                                ": valid must be a bool tensor of the map's shape");
  }
  const int64_t pixels = dense.size(-1) * dense.size(-2);
  const int64_t batch = pixels > 0 ? dense.numel() / pixels : 0;
  const at::Tensor values = dense.reshape({batch, pixels});
  return {values, valid.reshape({batch, pixels}).logical_and(at::isfinite(values)),
          dense.sizes().vec()};
}

// init (1-D) lowered to the smallest of `values` at each position of `index`:
// scatter_reduce(0, index, values, "amin") without that API, which LibTorch 1.13 marks beta and
// which then warns on every run's first point cloud. Sorting by value and then stably by index
// puts each index's minimum first in its run.
at::Tensor scatter_amin(const at::Tensor& init, const at::Tensor& index, const at::Tensor& values) {
  if (index.numel() == 0) return init;
  const c10::optional<bool> stable = true;  // (a bare `true` would pick sort(dim, descending))
  const at::Tensor by_value = std::get<1>(values.sort(stable, 0));
  const at::Tensor order =
      by_value.index_select(0, std::get<1>(index.index_select(0, by_value).sort(stable, 0)));
  const at::Tensor sorted_index = index.index_select(0, order);
  const at::Tensor first = at::ones_like(sorted_index, at::kBool);
  first.slice(0, 1).copy_(sorted_index.slice(0, 1) != sorted_index.slice(0, 0, -1));
  const at::Tensor targets = sorted_index.masked_select(first);
  const at::Tensor minima = values.index_select(0, order).masked_select(first);
  return init.index_put({targets}, at::minimum(init.index_select(0, targets), minima));
}

void check_generator(const at::Generator& generator, const char* function) {
  if (!generator.defined() || !generator.device().is_cpu()) {
    throw std::invalid_argument(std::string(function) + ": expected a CPU generator (seeded)");
  }
}

SparseDepth unflatten(const Flat& flat, const at::Tensor& selected) {
  const at::Tensor depth = at::where(selected, flat.values, at::zeros_like(flat.values));
  return {depth.reshape(flat.shape), selected.reshape(flat.shape)};
}

// The first `counts` (B) valid pixels of each item in a random order.
SparseDepth sample_counts(const Flat& flat, const at::Tensor& counts, at::Generator generator) {
  const int64_t batch = flat.values.size(0), pixels = flat.values.size(1);
  const at::Tensor keys =
      at::rand({batch, pixels}, generator, at::kDouble).to(flat.values.device());
  // Invalid pixels sort after every valid one.
  const at::Tensor order =
      at::where(flat.valid, keys, at::full_like(keys, 2.0)).argsort(/*dim=*/int64_t{1});
  const at::Tensor position = at::arange(pixels, order.options()).expand({batch, pixels});
  const at::Tensor rank = at::empty_like(order).scatter_(1, order, position);
  return unflatten(flat, (rank < counts.unsqueeze(1)).logical_and(flat.valid));
}

// Angle between unit vectors (..., 3), accurate for small angles.
at::Tensor angle_between(const at::Tensor& a, const at::Tensor& b) {
  return at::atan2(at::cross(a, b, -1).norm(2, -1), (a * b).sum(-1));
}

}  // namespace

SparseDepth sample_uniform(const at::Tensor& dense, const at::Tensor& valid, std::int64_t count,
                           at::Generator generator) {
  const Flat flat = flatten_map(dense, valid, "sample_uniform");
  check_generator(generator, "sample_uniform");
  if (count < 0) throw std::invalid_argument("sample_uniform: the sample count must be >= 0");
  const at::Tensor counts =
      at::full({flat.values.size(0)}, count, flat.values.options().dtype(at::kLong));
  return sample_counts(flat, counts, generator);
}

SparseDepth sample_uniform_ratio(const at::Tensor& dense, const at::Tensor& valid, double ratio,
                                 at::Generator generator) {
  const Flat flat = flatten_map(dense, valid, "sample_uniform_ratio");
  check_generator(generator, "sample_uniform_ratio");
  if (!(ratio > 0 && ratio <= 1))
    throw std::invalid_argument("sample_uniform_ratio: ratio must lie in (0, 1]");
  const at::Tensor available = flat.valid.sum(1);
  const at::Tensor counts = at::minimum(
      (available.to(at::kDouble) * ratio).round().to(at::kLong).clamp_min(1), available);
  return sample_counts(flat, counts, generator);
}

SparseDepth sample_lidar(const at::Tensor& dense, const at::Tensor& valid, const at::Tensor& rays,
                         const LidarPattern& pattern) {
  const Flat flat = flatten_map(dense, valid, "sample_lidar");
  const int64_t height = dense.size(-2), width = dense.size(-1), pixels = height * width;
  const int64_t batch = flat.values.size(0);
  const auto map_shape = dense.sizes();
  const bool shared = rays.defined() && rays.dim() == 3;
  if (!rays.defined() || rays.size(-1) != 3 || !at::isFloatingType(rays.scalar_type()) ||
      !(shared ? rays.size(0) == height && rays.size(1) == width
               : rays.sizes().slice(0, rays.dim() - 1) == map_shape)) {
    throw std::invalid_argument(
        "sample_lidar: rays must be (H, W, 3) or (..., H, W, 3) matching the map");
  }
  if (pattern.beams < 1 || pattern.azimuth_steps < 1 || !std::isfinite(pattern.min_elevation_deg) ||
      !std::isfinite(pattern.max_elevation_deg) ||
      pattern.max_elevation_deg < pattern.min_elevation_deg || pattern.min_elevation_deg < -90 ||
      pattern.max_elevation_deg > 90) {
    throw std::invalid_argument(
        "sample_lidar: expected beams >= 1, azimuth_steps >= 1 and -90 <= min <= max <= 90 degrees "
        "elevation");
  }
  const int64_t ray_items = shared ? 1 : batch;
  const at::Tensor r = rays.reshape({ray_items, height, width, 3}).to(flat.values.scalar_type());
  const at::Tensor ray_ok = r.ne(0).any(-1);

  // Each pixel's angular footprint: the largest angle to a valid 4-neighbour.
  at::Tensor spacing = at::zeros({ray_items, height, width}, r.options());
  const auto neighbour_angle = [&](int64_t dim, bool forward) {
    const int64_t n = r.size(dim);
    if (n < 2) return;
    const at::Tensor a = r.narrow(dim, forward ? 0 : 1, n - 1);
    const at::Tensor b = r.narrow(dim, forward ? 1 : 0, n - 1);
    const at::Tensor both = a.ne(0).any(-1).logical_and(b.ne(0).any(-1));
    const at::Tensor angle =
        at::where(both, angle_between(a, b), at::zeros_like(both, r.options()));
    spacing.narrow(dim, forward ? 0 : 1, n - 1)
        .copy_(at::maximum(spacing.narrow(dim, forward ? 0 : 1, n - 1), angle));
  };
  neighbour_angle(1, true);
  neighbour_angle(1, false);
  neighbour_angle(2, true);
  neighbour_angle(2, false);

  // The nearest beam (elevation index) and firing (azimuth index) of every pixel's ray.
  const double deg = M_PI / 180.0;
  const double min_elevation = pattern.min_elevation_deg * deg;
  const double elevation_step =
      pattern.beams > 1
          ? (pattern.max_elevation_deg - pattern.min_elevation_deg) * deg / (pattern.beams - 1)
          : 1.0;
  const double azimuth_step = 2 * M_PI / pattern.azimuth_steps;
  const at::Tensor elevation = at::asin((-r.select(-1, 1)).clamp(-1, 1));
  const at::Tensor azimuth = at::atan2(r.select(-1, 0), r.select(-1, 2));
  const at::Tensor beam = ((elevation - min_elevation) / elevation_step).round().to(at::kLong);
  const at::Tensor firing =
      at::remainder((azimuth / azimuth_step).round().to(at::kLong), pattern.azimuth_steps);
  const at::Tensor beam_elevation = min_elevation + beam.to(r.scalar_type()) * elevation_step;
  const at::Tensor firing_azimuth = firing.to(r.scalar_type()) * azimuth_step;
  const at::Tensor direction =
      at::stack({beam_elevation.cos() * firing_azimuth.sin(), -beam_elevation.sin(),
                 beam_elevation.cos() * firing_azimuth.cos()},
                -1);
  const at::Tensor error = angle_between(r, direction);
  const at::Tensor candidate = ray_ok.logical_and(beam >= 0)
                                   .logical_and(beam < pattern.beams)
                                   .logical_and(error <= spacing * (0.5 * std::sqrt(2.0)));

  // Per (item, beam, firing) cell, the pixel with the smallest error wins (ties: lowest index).
  const int64_t cells = pattern.beams * pattern.azimuth_steps;
  const at::Tensor item = at::arange(ray_items, beam.options()).view({ray_items, 1, 1});
  const at::Tensor cell = at::where(candidate, item * cells + beam * pattern.azimuth_steps + firing,
                                    at::zeros_like(beam))
                              .reshape(-1);
  const double inf = std::numeric_limits<double>::infinity();
  const at::Tensor masked_error =
      at::where(candidate, error, at::full_like(error, inf)).reshape(-1);
  const at::Tensor best =
      scatter_amin(at::full({ray_items * cells}, inf, r.options()), cell, masked_error);
  const at::Tensor index = at::arange(ray_items * pixels, beam.options());
  const at::Tensor ties =
      candidate.reshape(-1).logical_and(masked_error == best.index_select(0, cell));
  const int64_t none = ray_items * pixels;
  const at::Tensor first = scatter_amin(at::full({ray_items * cells}, none, beam.options()), cell,
                                        at::where(ties, index, at::full_like(index, none)));
  const at::Tensor hit =
      ties.logical_and(first.index_select(0, cell) == index).view({ray_items, pixels});
  return unflatten(flat, hit.expand({batch, pixels}).logical_and(flat.valid));
}

SparseDepth add_noise(const SparseDepth& sparse, const DepthNoise& noise, at::Generator generator) {
  check_generator(generator, "add_noise");
  if (!sparse.depth.defined() || !sparse.valid.defined() ||
      sparse.depth.sizes() != sparse.valid.sizes() ||
      !at::isFloatingType(sparse.depth.scalar_type())) {
    throw std::invalid_argument("add_noise: expected sparse depth and validity of the same shape");
  }
  if (!(noise.relative_sigma >= 0) || !(noise.outlier_ratio >= 0 && noise.outlier_ratio <= 1) ||
      !(noise.outlier_max_factor >= 1) || !std::isfinite(noise.relative_sigma) ||
      !std::isfinite(noise.outlier_max_factor)) {
    throw std::invalid_argument(
        "add_noise: expected relative_sigma >= 0, outlier_ratio in [0, 1], outlier_max_factor >= "
        "1");
  }
  const auto shape = sparse.depth.sizes();
  const auto to_map = [&](const at::Tensor& t) { return t.to(sparse.depth.options()); };
  const at::Tensor gaussian = to_map(at::randn(shape, generator, at::kDouble));
  const at::Tensor pick =
      at::rand(shape, generator, at::kDouble).to(sparse.depth.device()) < noise.outlier_ratio;
  const at::Tensor spread = to_map(at::rand(shape, generator, at::kDouble) * 2 - 1);
  at::Tensor depth = sparse.depth * at::exp(gaussian * noise.relative_sigma);
  depth = at::where(pick, depth * at::exp(spread * std::log(noise.outlier_max_factor)), depth);
  return {at::where(sparse.valid, depth, at::zeros_like(depth)), sparse.valid};
}

SparseDepth rasterize_nearest(const at::Tensor& pixels, const at::Tensor& distance,
                              const at::Tensor& value, const at::Tensor& valid, std::int64_t width,
                              std::int64_t height) {
  if (!pixels.defined() || pixels.dim() < 2 || pixels.size(-1) != 2 ||
      !at::isFloatingType(pixels.scalar_type())) {
    throw std::invalid_argument("rasterize_nearest: pixels must be a floating tensor (..., N, 2)");
  }
  const auto point_shape = pixels.sizes().slice(0, pixels.dim() - 1);
  if (!distance.defined() || distance.sizes() != point_shape || !value.defined() ||
      value.sizes() != point_shape || !valid.defined() || valid.sizes() != point_shape ||
      valid.scalar_type() != at::kBool) {
    throw std::invalid_argument(
        "rasterize_nearest: distance, value (..., N) and bool valid (..., N) must match the "
        "pixels");
  }
  if (width < 1 || height < 1)
    throw std::invalid_argument("rasterize_nearest: the image size must be positive");
  const int64_t n = pixels.size(-2);
  int64_t batch = 1;
  for (std::size_t i = 0; i + 1 < point_shape.size(); ++i) batch *= point_shape[i];
  // One pass over the points with a depth test per pixel, on the CPU (a scatter-based
  // z-buffer took ~1 s for a million points here); tensors of other devices come back there.
  const auto cpu = at::TensorOptions().dtype(pixels.scalar_type());
  const at::Tensor p = pixels.reshape({batch, n, 2}).to(cpu).contiguous();
  const at::Tensor d = distance.reshape({batch, n}).to(cpu).contiguous();
  const at::Tensor v = value.reshape({batch, n}).to(cpu).contiguous();
  const at::Tensor ok = valid.reshape({batch, n}).to(at::kCPU).contiguous();
  const double inf = std::numeric_limits<double>::infinity();
  at::Tensor nearest = at::full({batch, height, width}, inf, cpu);
  at::Tensor stored = at::zeros({batch, height, width}, cpu);
  AT_DISPATCH_FLOATING_TYPES(p.scalar_type(), "rasterize_nearest", [&] {
    const scalar_t* xy = p.data_ptr<scalar_t>();
    const scalar_t* dist = d.data_ptr<scalar_t>();
    const scalar_t* val = v.data_ptr<scalar_t>();
    const bool* use = ok.data_ptr<bool>();
    scalar_t* best = nearest.data_ptr<scalar_t>();
    scalar_t* out = stored.data_ptr<scalar_t>();
    // Items are independent images, and so are bands of rows within one: a thread takes an
    // (item, band) pair and scans that item's points for its rows. The winner of a pixel does
    // not depend on the order of the points, so the result does not depend on the split.
    const int64_t bands =
        std::clamp<int64_t>(at::get_num_threads() / std::max<int64_t>(batch, 1), 1, height);
    const int64_t band_rows = (height + bands - 1) / bands;
    util::parallel_for(0, batch * bands, 1, [&](int64_t first, int64_t last) {
      for (int64_t task = first; task < last; ++task) {
        const int64_t item = task / bands, band = task % bands;
        const auto top = static_cast<scalar_t>(band * band_rows);
        const auto bottom = static_cast<scalar_t>(std::min(height, (band + 1) * band_rows));
        scalar_t* item_best = best + item * height * width;
        scalar_t* item_out = out + item * height * width;
        for (int64_t i = item * n; i < (item + 1) * n; ++i) {
          const scalar_t col = std::floor(xy[2 * i]), row = std::floor(xy[2 * i + 1]);
          const scalar_t z = dist[i], stored_value = val[i];
          // Negated comparisons drop NaN coordinates as well.
          if (!use[i] || !(col >= 0 && col < width && row >= top && row < bottom) ||
              !std::isfinite(z) || !(z > 0) || !std::isfinite(stored_value))
            continue;
          const int64_t cell = static_cast<int64_t>(row) * width + static_cast<int64_t>(col);
          if (z < item_best[cell] || (z == item_best[cell] && stored_value < item_out[cell])) {
            item_best[cell] = z;
            item_out[cell] = stored_value;
          }
        }
      }
    });
  });
  auto shape = std::vector<int64_t>(point_shape.begin(), point_shape.end() - 1);
  shape.push_back(height);
  shape.push_back(width);
  const auto device = pixels.device();
  return {stored.reshape(shape).to(device), at::isfinite(nearest).reshape(shape).to(device)};
}

at::Tensor resize_sparse_map(const at::Tensor& map, std::int64_t width, std::int64_t height) {
  if (!map.defined() || map.dim() != 2 || !at::isFloatingType(map.scalar_type()))
    throw std::invalid_argument("resize_sparse_map: expected a floating (H, W) map");
  const at::Tensor present = at::isfinite(map) & (map > 0);
  const at::Tensor rows_cols = present.nonzero();  // (N, 2) row, column
  const at::Tensor centres = rows_cols.flip(1).to(at::kDouble) + 0.5;
  const at::Tensor scale =
      at::tensor({double(width) / map.size(1), double(height) / map.size(0)}, at::kDouble);
  const at::Tensor values = map.index({present}).to(at::kDouble);
  return rasterize_nearest(centres * scale, values, values, at::ones({values.size(0)}, at::kBool),
                           width, height)
      .depth.to(map.scalar_type());
}

void SweepOcclusion::Check() const {
  if (!(occlusion_margin > 0 && occlusion_margin < 1))
    throw std::invalid_argument("sweep occlusion: the margin must be in (0, 1), got " +
                                std::to_string(occlusion_margin));
  if (min_neighbours < 1)
    throw std::invalid_argument("sweep occlusion: min_neighbours must be >= 1, got " +
                                std::to_string(min_neighbours));
  if (max_radius < 0)
    throw std::invalid_argument("sweep occlusion: max_radius must be >= 0, got " +
                                std::to_string(max_radius));
}

namespace {

// kSensorSweep's occlusion test (sparse_sampling.h): pixels (B, N, 2), distances (B, N) and
// validity (B, N) on the CPU; true where a return is hidden behind nearer returns around it.
at::Tensor hidden_returns(const at::Tensor& pixels, const at::Tensor& distance,
                          const at::Tensor& valid, int64_t width, int64_t height,
                          const SweepOcclusion& occlusion) {
  const int64_t batch = pixels.size(0), cells = width * height;
  const at::Tensor col = pixels.select(-1, 0).floor(), row = pixels.select(-1, 1).floor();
  const at::Tensor inside = valid & (col >= 0) & (col < width) & (row >= 0) & (row < height);
  const at::Tensor cell = at::where(inside, row * width + col, at::zeros_like(col)).to(at::kLong);
  const double inf = std::numeric_limits<double>::infinity();
  const SparseDepth zbuffer = rasterize_nearest(pixels, distance, distance, inside, width, height);
  const at::Tensor nearest =
      at::where(zbuffer.valid, zbuffer.depth.to(at::kDouble), at::full({}, inf, at::kDouble))
          .unsqueeze(1);  // (B, 1, H, W)
  const at::Tensor count = at::zeros({batch, cells}, at::kDouble)
                               .scatter_add_(1, cell, inside.to(at::kDouble))
                               .view({batch, 1, height, width});
  at::Tensor front = at::full({batch, pixels.size(1)}, inf, at::kDouble);
  at::Tensor margin = at::zeros({batch, pixels.size(1)}, at::kDouble);
  at::Tensor settled = ~inside;
  for (int64_t radius = 0; radius <= occlusion.max_radius; ++radius) {
    const int64_t size = 2 * radius + 1;
    // The window's nearest return and its number of returns (its own included).
    const at::Tensor window_nearest =
        radius == 0 ? nearest : -at::max_pool2d(-nearest, {size, size}, {1, 1}, {radius, radius});
    const at::Tensor window_count =
        radius == 0 ? count
                    : at::avg_pool2d(count, {size, size}, {1, 1}, {radius, radius}) *
                          static_cast<double>(size * size);
    const at::Tensor enough = radius == occlusion.max_radius
                                  ? at::ones_like(settled)
                                  : window_count.view({batch, cells}).gather(1, cell) >
                                        static_cast<double>(occlusion.min_neighbours) + 0.5;
    const at::Tensor take = ~settled & enough;
    front = at::where(take, window_nearest.view({batch, cells}).gather(1, cell), front);
    // A smooth surface changes in proportion to the window's width: so does the margin.
    margin = at::where(take, at::full({}, occlusion.occlusion_margin * (1.0 + radius)), margin);
    settled = settled | take;
  }
  const at::Tensor d = distance.to(at::kDouble);
  return inside & (d - front > margin * d);
}

}  // namespace

SparseDepth sparse_depth_from_points(const at::Tensor& points, const camera::Camera& camera,
                                     const at::Tensor& valid, SparseValue value,
                                     PointSelection selection, const SweepOcclusion& occlusion) {
  if (!points.defined() || points.dim() < 2 || points.size(-1) != 3 ||
      !at::isFloatingType(points.scalar_type())) {
    throw std::invalid_argument(
        "sparse_depth_from_points: points must be a floating tensor (..., N, 3)");
  }
  const auto point_shape = points.sizes().slice(0, points.dim() - 1);
  if (valid.defined() && (valid.scalar_type() != at::kBool || valid.sizes() != point_shape)) {
    throw std::invalid_argument("sparse_depth_from_points: valid must be a bool tensor (..., N)");
  }
  const camera::Pixels projected = camera.project(points);
  at::Tensor ok = projected.valid.logical_and(at::isfinite(points).all(-1));
  if (valid.defined()) ok = ok.logical_and(valid);
  const at::Tensor distance = points.norm(2, -1);
  const at::Tensor stored = value == SparseValue::Distance ? distance : points.select(-1, 2);
  if (selection == PointSelection::kNearest)
    return rasterize_nearest(projected.pixels, distance, stored, ok, camera.width(),
                             camera.height());
  occlusion.Check();
  // On the CPU in float64, as (batch, N).
  const int64_t n = points.size(-2);
  int64_t batch = 1;
  for (std::size_t i = 0; i + 1 < point_shape.size(); ++i) batch *= point_shape[i];
  const auto flat = [&](const at::Tensor& t) {
    return t.reshape({batch, n})
        .to(at::kCPU, t.scalar_type() == at::kBool ? at::kBool : at::kDouble);
  };
  const at::Tensor pixels = projected.pixels.reshape({batch, n, 2}).to(at::kCPU, at::kDouble);
  const at::Tensor usable =
      flat(ok.logical_and(at::isfinite(projected.pixels).all(-1)).logical_and(distance > 0));
  const at::Tensor hidden =
      hidden_returns(pixels, flat(distance), usable, camera.width(), camera.height(), occlusion);
  // The rasteriser keeps a pixel's smallest key: here 1 + the squared offset from its centre.
  const at::Tensor offset = (pixels - pixels.floor() - 0.5).pow(2).sum(-1) + 1.0;
  const SparseDepth kept = rasterize_nearest(pixels, offset, flat(stored), usable & ~hidden,
                                             camera.width(), camera.height());
  auto shape = std::vector<int64_t>(point_shape.begin(), point_shape.end() - 1);
  shape.push_back(camera.height());
  shape.push_back(camera.width());
  return {kept.depth.reshape(shape).to(points.device(), points.scalar_type()),
          kept.valid.reshape(shape).to(points.device())};
}

}  // namespace omnipoint::geometry
