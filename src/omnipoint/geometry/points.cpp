#include "omnipoint/geometry/points.h"

#include <ATen/ATen.h>

#include <stdexcept>
#include <string>

namespace omnipoint::geometry {
namespace {

void check_vectors(const at::Tensor& t, const char* function, const char* name) {
  if (!t.defined() || t.dim() < 1 || t.size(-1) != 3 || !at::isFloatingType(t.scalar_type())) {
    throw std::invalid_argument(std::string(function) + ": " + name +
                                " must be a floating tensor of shape (..., 3)");
  }
}

// v / |v| where |v| > 0, zero elsewhere (no NaN for zero or non-finite vectors).
at::Tensor normalized_or_zero(const at::Tensor& v) {
  const at::Tensor norm = v.norm(2, -1, /*keepdim=*/true);
  const at::Tensor ok = (norm > 0).logical_and(at::isfinite(norm));
  return at::where(ok, v / at::where(ok, norm, at::ones_like(norm)), at::zeros_like(v));
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
  at::Tensor mask = at::isfinite(points).all(-1);
  if (valid.defined()) mask = mask.logical_and(valid);
  const at::Tensor clean = at::where(mask.unsqueeze(-1), points, at::zeros_like(points));
  const int64_t h = points.size(-3), w = points.size(-2);
  // Pad by one pixel (invalid) so that every pixel has four neighbours.
  const at::Tensor p = at::constant_pad_nd(clean, {0, 0, 1, 1, 1, 1}, 0);
  const at::Tensor m = at::constant_pad_nd(mask.to(at::kByte), {1, 1, 1, 1}, 0).to(at::kBool);
  const auto shifted = [&](const at::Tensor& t, int64_t dy, int64_t dx, int64_t row_dim) {
    return t.narrow(row_dim, 1 + dy, h).narrow(row_dim + 1, 1 + dx, w);
  };
  const int64_t prow = p.dim() - 3, mrow = m.dim() - 2;
  const at::Tensor up = shifted(p, -1, 0, prow) - clean, left = shifted(p, 0, -1, prow) - clean;
  const at::Tensor down = shifted(p, 1, 0, prow) - clean, right = shifted(p, 0, 1, prow) - clean;
  const at::Tensor up_ok = shifted(m, -1, 0, mrow), left_ok = shifted(m, 0, -1, mrow);
  const at::Tensor down_ok = shifted(m, 1, 0, mrow), right_ok = shifted(m, 0, 1, mrow);

  // In image orientation (x right, y down), up × left faces the camera for a frontal plane.
  at::Tensor sum = at::zeros_like(clean);
  at::Tensor any = at::zeros_like(mask);
  const auto add = [&](const at::Tensor& a, const at::Tensor& b, const at::Tensor& ok) {
    sum = sum + normalized_or_zero(at::cross(a, b, -1)) * ok.unsqueeze(-1).to(clean.scalar_type());
    any = any.logical_or(ok);
  };
  add(up, left, up_ok & left_ok);
  add(left, down, left_ok & down_ok);
  add(down, right, down_ok & right_ok);
  add(right, up, right_ok & up_ok);
  at::Tensor normals = normalized_or_zero(sum);
  const at::Tensor facing_away = (normals * clean).sum(-1, /*keepdim=*/true) > 0;
  normals = at::where(facing_away, -normals, normals);
  const at::Tensor ok = any.logical_and(mask).logical_and(normals.ne(0).any(-1));
  return {at::where(ok.unsqueeze(-1), normals, at::zeros_like(normals)), ok};
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
  at::Tensor valid = at::isfinite(point_map).all(-1);
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
  const at::Tensor keep = cloud.valid.nonzero().squeeze(1);
  return {cloud.points.index_select(0, keep),
          cloud.colors.defined() ? cloud.colors.index_select(0, keep) : at::Tensor(),
          at::ones({keep.size(0)}, cloud.valid.options())};
}

}  // namespace omnipoint::geometry
