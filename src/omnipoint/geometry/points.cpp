#include "omnipoint/geometry/points.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "omnipoint/camera/camera_model.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::geometry {
namespace {

void check_vectors(const at::Tensor& t, const char* function, const char* name) {
  if (!t.defined() || t.dim() < 1 || t.size(-1) != 3 || !at::isFloatingType(t.scalar_type())) {
    throw std::invalid_argument(std::string(function) + ": " + name +
                                " must be a floating tensor of shape (..., 3)");
  }
}

}  // namespace

at::Tensor points_from_rays(const at::Tensor& rays, const at::Tensor& distance) {
  check_vectors(rays, "points_from_rays", "rays");
  if (!distance.defined() || !at::isFloatingType(distance.scalar_type())) {
    throw std::invalid_argument("points_from_rays: distance must be a floating tensor (...)");
  }
  return rays * distance.unsqueeze(-1);
}

RaysAndDistance rays_from_points(const at::Tensor& points) {
  check_vectors(points, "rays_from_points", "points");
  const at::Tensor norm = points.norm(2, -1);
  const at::Tensor valid = (norm > 0).logical_and(at::isfinite(norm));
  const at::Tensor safe = at::where(valid, norm, at::ones_like(norm));
  const at::Tensor rays =
      at::where(valid.unsqueeze(-1), points / safe.unsqueeze(-1), at::zeros_like(points));
  return {rays, at::where(valid, norm, at::zeros_like(norm)), valid};
}

at::Tensor planar_depth(const at::Tensor& points) {
  check_vectors(points, "planar_depth", "points");
  return points.select(-1, 2);
}

DistanceFromDepth distance_from_planar_depth(const at::Tensor& depth, const at::Tensor& rays) {
  check_vectors(rays, "distance_from_planar_depth", "rays");
  if (!depth.defined() || !at::isFloatingType(depth.scalar_type())) {
    throw std::invalid_argument(
        "distance_from_planar_depth: depth must be a floating tensor (...)");
  }
  const at::Tensor forward = rays.select(-1, 2);
  const at::Tensor safe = at::where(forward > 0, forward, at::ones_like(forward));
  const at::Tensor distance = depth / safe;
  const at::Tensor valid = (forward > 0).logical_and(depth > 0).logical_and(at::isfinite(distance));
  return {at::where(valid, distance, at::zeros_like(distance)), valid};
}

Normals normals_from_point_map(const at::Tensor& points, const at::Tensor& valid) {
  check_vectors(points, "normals_from_point_map", "points");
  if (points.dim() < 3) {
    throw std::invalid_argument("normals_from_point_map: points must have shape (..., H, W, 3)");
  }
  const auto map_shape = points.sizes().slice(0, points.dim() - 1);
  if (valid.defined() && (valid.scalar_type() != at::kBool || valid.sizes() != map_shape)) {
    throw std::invalid_argument(
        "normals_from_point_map: valid must be a bool tensor of shape (..., H, W)");
  }
  // One pass over contiguous CPU data, rows in parallel: the tensor formulation (a dozen
  // full-size temporaries, cross products over a length-3 last dimension) took seconds at 12 MP.
  const bool native = points.scalar_type() == at::kFloat || points.scalar_type() == at::kDouble;
  const at::Tensor p = points.to(at::kCPU, native ? points.scalar_type() : at::kFloat).contiguous();
  const at::Tensor given = valid.defined() ? valid.to(at::kCPU).contiguous() : at::Tensor();
  const int64_t height = points.size(-3), width = points.size(-2);
  const int64_t rows = p.numel() == 0 ? 0 : p.numel() / (3 * width);  // (..., H) map rows
  at::Tensor normals = at::empty_like(p);
  at::Tensor ok = at::empty(map_shape, p.options().dtype(at::kBool));
  at::Tensor usable = at::empty(map_shape, p.options().dtype(at::kBool));
  AT_DISPATCH_FLOATING_TYPES(p.scalar_type(), "normals_from_point_map", [&] {
    using Vec = std::array<scalar_t, 3>;
    const scalar_t* in = p.data_ptr<scalar_t>();
    const bool* given_ok = given.defined() ? given.data_ptr<bool>() : nullptr;
    bool* use = usable.data_ptr<bool>();
    const int64_t grain = std::max<int64_t>(1, 16384 / std::max<int64_t>(width, 1));
    util::parallel_for(0, rows * width, grain * width, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i)
        use[i] = (given_ok == nullptr || given_ok[i]) && std::isfinite(in[3 * i]) &&
                 std::isfinite(in[3 * i + 1]) && std::isfinite(in[3 * i + 2]);
    });
    scalar_t* out = normals.data_ptr<scalar_t>();
    bool* out_ok = ok.data_ptr<bool>();
    const auto at_pixel = [&](int64_t i) { return Vec{in[3 * i], in[3 * i + 1], in[3 * i + 2]}; };
    const auto minus = [](const Vec& a, const Vec& b) {
      return Vec{a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    };
    const auto norm = [](const Vec& v) {
      return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    };
    util::parallel_for(0, rows, grain, [&](int64_t row_begin, int64_t row_end) {
      for (int64_t row = row_begin; row < row_end; ++row) {
        const int64_t y = row % height;
        for (int64_t x = 0; x < width; ++x) {
          const int64_t i = row * width + x;
          Vec sum{0, 0, 0};
          bool any = false;
          if (use[i]) {
            const Vec centre = at_pixel(i);
            // up, left, down, right: in image orientation (x right, y down) up × left faces
            // the camera for a frontal plane, and so does each next pair in this order.
            const int64_t neighbour[4] = {i - width, i - 1, i + width, i + 1};
            const bool inside[4] = {y > 0, x > 0, y + 1 < height, x + 1 < width};
            Vec difference[4] = {};
            bool present[4];
            for (int k = 0; k < 4; ++k) {
              present[k] = inside[k] && use[neighbour[k]];
              if (present[k]) difference[k] = minus(at_pixel(neighbour[k]), centre);
            }
            for (int k = 0; k < 4; ++k) {
              const int next = (k + 1) % 4;
              if (!present[k] || !present[next]) continue;
              any = true;
              const Vec& a = difference[k];
              const Vec& b = difference[next];
              const Vec cross{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                              a[0] * b[1] - a[1] * b[0]};
              const scalar_t length = norm(cross);
              if (length > 0 && std::isfinite(length))
                for (int c = 0; c < 3; ++c) sum[c] += cross[c] / length;
            }
            const scalar_t length = norm(sum);
            if (length > 0 && std::isfinite(length)) {
              // Oriented towards the camera: n · P <= 0.
              const scalar_t sign =
                  sum[0] * centre[0] + sum[1] * centre[1] + sum[2] * centre[2] > 0 ? -1 : 1;
              for (int c = 0; c < 3; ++c) sum[c] = sign * (sum[c] / length);
            } else {
              sum = Vec{0, 0, 0};
            }
          }
          out_ok[i] = any && (sum[0] != 0 || sum[1] != 0 || sum[2] != 0);
          for (int c = 0; c < 3; ++c) out[3 * i + c] = out_ok[i] ? sum[c] : scalar_t(0);
        }
      }
    });
  });
  return {normals.to(points.device(), points.scalar_type()), ok.to(points.device())};
}

PointCloud make_point_cloud(const at::Tensor& point_map, const at::Tensor& image,
                            const at::Tensor& mask) {
  check_vectors(point_map, "make_point_cloud", "point_map");
  if (point_map.dim() < 3 || !image.defined() || image.sizes() != point_map.sizes()) {
    throw std::invalid_argument(
        "make_point_cloud: expected a point map (..., H, W, 3) and an RGB image of the same shape");
  }
  const auto map_shape = point_map.sizes().slice(0, point_map.dim() - 1);
  if (mask.defined() && (mask.scalar_type() != at::kBool || mask.sizes() != map_shape)) {
    throw std::invalid_argument(
        "make_point_cloud: mask must be a bool tensor of shape (..., H, W)");
  }
  // Element-wise: ATen's reduction over the length-3 last dimension is several times slower.
  at::Tensor valid = camera::all_finite(point_map);
  if (mask.defined()) valid = valid.logical_and(mask);
  at::Tensor colors;
  if (image.scalar_type() == at::kByte) {
    colors = image;
  } else if (at::isFloatingType(image.scalar_type())) {
    colors = (at::nan_to_num(image, 0.0).clamp(0, 1) * 255).round().to(at::kByte);
  } else {
    throw std::invalid_argument("make_point_cloud: the image must be uint8 or floating in [0, 1]");
  }
  auto flat = point_map.sizes().vec();
  flat.erase(flat.end() - 3, flat.end());
  flat.push_back(point_map.size(-3) * point_map.size(-2));
  auto flat3 = flat;
  flat3.push_back(3);
  const at::Tensor points = at::where(valid.unsqueeze(-1), point_map, at::zeros_like(point_map));
  return {points.reshape(flat3), colors.reshape(flat3), valid.reshape(flat)};
}

PointCloud valid_points(const PointCloud& cloud) {
  if (!cloud.points.defined() || cloud.points.dim() != 2 || !cloud.valid.defined() ||
      cloud.valid.dim() != 1 || cloud.valid.size(0) != cloud.points.size(0)) {
    throw std::invalid_argument(
        "valid_points: expected an unbatched cloud of (N, 3) points with (N) validity");
  }
  // Every point valid (a scene without sky): no index list and no copies.
  if (cloud.valid.all().item<bool>()) return cloud;
  const at::Tensor keep = cloud.valid.nonzero().squeeze(1);
  return {cloud.points.index_select(0, keep),
          cloud.colors.defined() ? cloud.colors.index_select(0, keep) : at::Tensor(),
          at::ones({keep.size(0)}, cloud.valid.options())};
}

}  // namespace omnipoint::geometry
