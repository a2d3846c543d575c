#pragma once
// Rotations and 4x4 poses for the rig tests (float64), and a pose as a rig file writes it.
#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

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

// The 3x4 rows of a rig file's pose.
inline nlohmann::json pose_rows(const at::Tensor& m) {
  nlohmann::json out = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < 4; ++j) row.push_back(m[i][j].item<double>());
    out.push_back(row);
  }
  return out;
}

}  // namespace omnipoint::predict::test_rig
