#include "omnipoint/geometry/point_rays.h"

#include <ATen/ATen.h>

#include <stdexcept>

namespace omnipoint::geometry {

RaysAndDistance rays_and_distance(const at::Tensor& points) {
  if (points.dim() < 1 || points.size(-1) != 3)
    throw std::invalid_argument("rays_and_distance: points must be (..., 3), got " + c10::str(points.sizes()));
  const at::Tensor distance = at::linalg_vector_norm(points, 2, {-1});
  const at::Tensor usable = at::isfinite(distance) & (distance > 0);
  const at::Tensor rays = at::where(usable.unsqueeze(-1), points / distance.unsqueeze(-1), at::zeros_like(points));
  return {rays, distance};
}

}  // namespace omnipoint::geometry
