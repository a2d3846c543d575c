#pragma once
// A point map as rays and distances: P = d · r with unit rays r and distances d = ‖P‖
// (DESIGN.md). Lets every consumer treat point-map models (MoGe-2) and ray/distance models
// (OmniPoint) alike.
#include <ATen/core/Tensor.h>

namespace omnipoint::geometry {

struct RaysAndDistance {
  at::Tensor rays;      // (..., 3) unit vectors; zero where the point is at the origin
  at::Tensor distance;  // (...) ‖P‖; +inf where P has an infinite coordinate
};

// points: (..., 3). Rays of infinite points (masked pixels) are zero.
RaysAndDistance rays_and_distance(const at::Tensor& points);

}  // namespace omnipoint::geometry
