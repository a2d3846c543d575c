#include "omnipoint/data/formats/lidar_labels.h"

#include <ATen/ATen.h>

#include <cmath>
#include <stdexcept>

#include "omnipoint/geometry/sparse_sampling.h"

namespace omnipoint::data {

PrincipalPoint parse_principal_point(const std::string& text, const std::string& what) {
  if (text == "integer-centre") return PrincipalPoint::kIntegerCentre;
  if (text == "corner") return PrincipalPoint::kCorner;
  throw std::invalid_argument(what + ": principal_point \"" + text +
                              "\": expected integer-centre or corner");
}

double principal_point_shift(PrincipalPoint reading) {
  return reading == PrincipalPoint::kIntegerCentre ? 0.5 : 0.0;
}

LidarRule parse_lidar_rule(const std::string& text, const std::string& what) {
  if (text == "nearest") return LidarRule::kNearest;
  if (text == "dac") return LidarRule::kDac;
  throw std::invalid_argument(what + ": gt_rule \"" + text + "\": expected nearest or dac");
}

LidarLabels lidar_labels(const at::Tensor& points, const camera::Camera& camera,
                         const LidarProjection& projection) {
  if (!points.defined() || points.dim() != 2 || points.size(1) != 3)
    throw std::invalid_argument("lidar_labels: expected points (N, 3)");
  const at::Tensor xyz = points.to(at::kDouble).contiguous();
  if (projection.rule == LidarRule::kNearest) {
    const geometry::SparseDepth sparse = geometry::sparse_depth_from_points(xyz, camera);
    return {sparse.depth.to(at::kFloat).contiguous(), sparse.valid.contiguous()};
  }
  const int64_t width = camera.width(), height = camera.height();
  const camera::Pixels projected = camera.project(xyz);
  const at::Tensor pixels = projected.pixels.contiguous();
  const at::Tensor valid = projected.valid.contiguous();
  at::Tensor distance = at::zeros({height, width}, at::kFloat);
  float* out = distance.data_ptr<float>();
  const double* xy = pixels.data_ptr<double>();
  const double* p = xyz.data_ptr<double>();
  const bool* ok = valid.data_ptr<bool>();
  const auto to_index = [&](double coordinate) {
    const double devkit = coordinate - projection.devkit_shift;
    return projection.round ? std::nearbyint(devkit) : std::trunc(devkit);
  };
  for (int64_t i = 0; i < xyz.size(0); ++i) {  // in file order: the last point wins
    const double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
    if (!ok[i] || !(z > 0)) continue;
    const double col = to_index(xy[2 * i]), row = to_index(xy[2 * i + 1]);
    if (!(col >= 0 && col < width && row >= 0 && row < height)) continue;
    out[static_cast<int64_t>(row) * width + static_cast<int64_t>(col)] =
        static_cast<float>(std::sqrt(x * x + y * y + z * z));
  }
  return {distance, distance > 0};
}

}  // namespace omnipoint::data
