#include "omnipoint/camera/lens_helpers.h"

#include <ATen/ATen.h>

#include <limits>

namespace omnipoint::camera {

std::vector<double> host_values(const at::Tensor& params) {
  const auto values = params.detach().to(at::kCPU, at::kDouble).contiguous();
  const double* data = values.data_ptr<double>();
  return std::vector<double>(data, data + values.numel());
}

NormalisedPixels normalise_finite_pixels(const CameraModel& model, const at::Tensor& params64,
                                         const at::Tensor& pixels) {
  const auto normalised =
      normalise_pixels(focal_principal(model, params64), pixels.detach().to(at::kDouble));
  const auto finite = all_finite(normalised);
  return {at::where(finite.unsqueeze(-1), normalised, at::zeros_like(normalised)), finite};
}

double fold_slack(at::ScalarType dtype) {
  return 8.0 * (dtype == at::kDouble ? std::numeric_limits<double>::epsilon()
                                     : std::numeric_limits<float>::epsilon());
}

at::Tensor tangential_distortion(const at::Tensor& xy, const at::Tensor& p1, const at::Tensor& p2) {
  const auto x = xy.select(-1, 0);
  const auto y = xy.select(-1, 1);
  const auto r2 = x * x + y * y;
  return at::stack(
      {2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x), p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y}, -1);
}

at::Tensor locally_invertible(const Map2D& g, const at::Tensor& u) {
  const auto j = jacobian_2d(g, u, g(u));
  const auto j00 = j.select(-1, 0).select(-1, 0);
  const auto j11 = j.select(-1, 1).select(-1, 1);
  const auto det = j00 * j11 - j.select(-1, 0).select(-1, 1) * j.select(-1, 1).select(-1, 0);
  return (det > 0) & (j00 + j11 > 0);
}

}  // namespace omnipoint::camera
