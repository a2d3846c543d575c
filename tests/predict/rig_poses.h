#pragma once
// Rotations and 4x4 poses for the rig tests (float64).
#include <ATen/ATen.h>

#include <cmath>
#include <vector>

namespace omnipoint::predict::test_rig {

inline at::Tensor rotation_y(double angle) {  // turns the camera's z (forward) towards +x
  return at::tensor({std::cos(angle), 0.0, std::sin(angle), 0.0, 1.0, 0.0, -std::sin(angle), 0.0,
                     std::cos(angle)},
                    at::kDouble)
      .view({3, 3});
}
inline at::Tensor rotation_x(double angle) {
  return at::tensor({1.0, 0.0, 0.0, 0.0, std::cos(angle), -std::sin(angle), 0.0, std::sin(angle),
                     std::cos(angle)},
                    at::kDouble)
      .view({3, 3});
}
inline at::Tensor pose(const at::Tensor& rotation, const std::vector<double>& translation) {
  at::Tensor m = at::eye(4, at::kDouble);
  m.slice(0, 0, 3).slice(1, 0, 3).copy_(rotation);
  m.slice(0, 0, 3).select(1, 3).copy_(at::tensor(translation, at::kDouble));
  return m;
}

}  // namespace omnipoint::predict::test_rig
