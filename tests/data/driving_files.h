#pragma once
// Files of driving datasets as the tests write them (KITTI raw, KITTI-360): rotations, text,
// Velodyne sweeps, and checks of one-line errors.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace omnipoint::test {

// A rotation by `angle` about the unit axis (x, y, z) (Rodrigues), (3, 3) float64.
inline at::Tensor rotation(double x, double y, double z, double angle) {
  const at::Tensor k = at::tensor({0.0, -z, y, z, 0.0, -x, -y, x, 0.0}, at::kDouble).view({3, 3});
  return at::eye(3, at::kDouble) + std::sin(angle) * k + (1 - std::cos(angle)) * at::matmul(k, k);
}

// (4, 4) float64 of a rotation (3, 3) and a translation (3).
inline at::Tensor rigid(const at::Tensor& rotation, const at::Tensor& translation) {
  at::Tensor matrix = at::eye(4, at::kDouble);
  matrix.narrow(0, 0, 3).narrow(1, 0, 3).copy_(rotation);
  matrix.narrow(0, 0, 3).select(1, 3).copy_(translation);
  return matrix;
}

// Points (N, 3) through a (4, 4) transform.
inline at::Tensor transformed(const at::Tensor& transform, const at::Tensor& points) {
  return at::matmul(points, transform.narrow(0, 0, 3).narrow(1, 0, 3).t()) +
         transform.narrow(0, 0, 3).select(1, 3);
}

// The KITTI devkits' number format ("%e": 9.999239e-01), space-separated, row-major.
inline std::string kitti_numbers(const at::Tensor& values) {
  std::string text;
  const at::Tensor flat = values.contiguous().view(-1);
  for (int64_t i = 0; i < flat.numel(); ++i) {
    char number[32];
    std::snprintf(number, sizeof number, "%e", flat[i].item<double>());
    text += (i ? " " : "") + std::string(number);
  }
  return text;
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// A Velodyne sweep: float32 x, y, z, reflectance per point.
inline void write_sweep(const std::filesystem::path& path, const at::Tensor& points) {
  const at::Tensor records =
      at::cat({points.to(at::kFloat), at::full({points.size(0), 1}, 0.25f)}, 1).contiguous();
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary)
      .write(static_cast<const char*>(records.data_ptr()), records.numel() * sizeof(float));
}

// "%010d", the frame file stem of both datasets.
inline std::string frame_stem(int frame) {
  char stem[16];
  std::snprintf(stem, sizeof stem, "%010d", frame);
  return stem;
}

inline std::string error_of(const std::function<void()>& run) {
  try {
    run();
  } catch (const std::exception& error) {
    return error.what();
  }
  return "(no error)";
}

// `run` fails with one line holding every part.
inline void expect_error(const std::function<void()>& run, const std::vector<std::string>& parts) {
  const std::string error = error_of(run);
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  for (const std::string& part : parts) EXPECT_NE(error.find(part), std::string::npos) << error;
}

}  // namespace omnipoint::test
