#include "omnipoint/camera/camera_info.h"

#include <ATen/ATen.h>

#include <cmath>
#include <set>
#include <string>

namespace omnipoint::camera {
namespace {

// Angle swept along the straight pixel path from `from` to `to`, in degrees.
double swept_angle(const Camera& camera, double x0, double y0, double x1, double y1) {
  constexpr int64_t kSteps = 4096;
  const auto t = at::linspace(0, 1, kSteps + 1, at::kDouble);
  const auto pixels = at::stack({x0 + (x1 - x0) * t, y0 + (y1 - y0) * t}, -1);
  const auto rays = camera.unproject(pixels);
  const auto a = rays.rays.narrow(0, 0, kSteps), b = rays.rays.narrow(0, 1, kSteps);
  const auto both = rays.valid.narrow(0, 0, kSteps) & rays.valid.narrow(0, 1, kSteps);
  // atan2(|a x b|, a . b) is accurate for the tiny angles between neighbours.
  const auto angles = at::atan2(length(at::cross(a, b, -1)), (a * b).sum(-1));
  return at::where(both, angles, at::zeros_like(angles)).sum().item<double>() * 180.0 / M_PI;
}

}  // namespace

FieldOfView field_of_view(const Camera& camera) {
  const double w = static_cast<double>(camera.width()), h = static_cast<double>(camera.height());
  return {swept_angle(camera, 0, 0.5 * h, w, 0.5 * h), swept_angle(camera, 0.5 * w, 0, 0.5 * w, h),
          swept_angle(camera, 0, 0, w, h)};
}

double valid_fraction(const Camera& camera) {
  return camera.ray_map(at::kFloat).valid.to(at::kDouble).mean().item<double>();
}

CameraClass camera_class(const Camera& camera) {
  static const std::set<std::string> wide{"OPENCV_FISHEYE",
                                          "SIMPLE_RADIAL_FISHEYE",
                                          "RADIAL_FISHEYE",
                                          "THIN_PRISM_FISHEYE",
                                          "RAD_TAN_THIN_PRISM_FISHEYE",
                                          "FOV",
                                          "MEI",
                                          "UCM",
                                          "EUCM",
                                          "DOUBLE_SPHERE"};
  if (camera.model_name() == "EQUIRECTANGULAR") return CameraClass::kPanorama;
  return wide.count(camera.model_name()) ? CameraClass::kWide : CameraClass::kPerspective;
}

}  // namespace omnipoint::camera
