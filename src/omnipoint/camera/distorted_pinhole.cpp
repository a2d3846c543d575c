#include "omnipoint/camera/distorted_pinhole.h"

#include <ATen/ATen.h>

#include "omnipoint/camera/solve.h"

namespace omnipoint::camera {

PlaneProjection project_to_plane(const at::Tensor& points) {
  const auto z = points.select(-1, 2);
  const auto valid = z > 0;
  const auto safe_z = at::where(valid, z, at::ones_like(z)).unsqueeze(-1);
  const auto normalised = points.narrow(-1, 0, 2) / safe_z;
  const auto finite = valid & all_finite(normalised);
  return {at::where(finite.unsqueeze(-1), normalised, at::zeros_like(normalised)), finite};
}

void DistortedPinholeModel::check_params(const std::vector<double>& params, ImageSize) const {
  check_focal_positive(*this, params);
}

double DistortedPinholeModel::monotonic_radius(const at::Tensor& params) const {
  const auto host_params = params.to(at::kCPU, at::kDouble);
  return camera::monotonic_radius([&](const at::Tensor& u) { return distort(host_params, u); });
}

Pixels DistortedPinholeModel::project(const at::Tensor& params, ImageSize,
                                      const at::Tensor& points) const {
  const auto plane = project_to_plane(points);
  const auto pixels =
      denormalise_pixels(focal_principal(*this, params), distort(params, plane.normalised));
  const auto valid =
      plane.valid & (length(plane.normalised) < monotonic_radius(params)) & all_finite(pixels);
  return {at::where(valid.unsqueeze(-1), pixels, at::zeros_like(pixels)), valid};
}

Rays DistortedPinholeModel::unproject(const at::Tensor& params, ImageSize,
                                      const at::Tensor& pixels) const {
  const auto params64 = params.to(at::kDouble);
  const Map2D g = [&](const at::Tensor& u) { return distort(params64, u); };
  const auto distorted = normalise_pixels(focal_principal(*this, params64), pixels.to(at::kDouble));
  // Start from one fixed-point step u = d - (g(d) - d), which removes the first-order
  // distortion; where that is worse than d itself (strong distortion), start from d.
  const auto stepped = 2 * distorted - g(distorted);
  const auto closer =
      squared_length(g(stepped) - distorted) < squared_length(g(distorted) - distorted);
  const auto initial = at::where(closer.unsqueeze(-1), stepped, distorted);
  const auto solved = solve_2d(g, distorted, initial, monotonic_radius(params));
  const auto rays = rays_from_plane(solved.solution);
  const auto valid = solved.converged;
  return {at::where(valid.unsqueeze(-1), rays, at::zeros_like(rays)).to(pixels.scalar_type()),
          valid};
}

}  // namespace omnipoint::camera
