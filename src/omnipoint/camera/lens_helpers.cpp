#include "omnipoint/camera/lens_helpers.h"

#include <ATen/ATen.h>

#include <limits>
#include <sstream>
#include <stdexcept>

namespace omnipoint::camera {

std::vector<double> host_values(const at::Tensor& params) {
  const auto values = params.detach().to(at::kCPU, at::kDouble).contiguous();
  const double* data = values.data_ptr<double>();
  return std::vector<double>(data, data + values.numel());
}

void require_param(const CameraModel& model, const std::string& name, double value, bool ok,
                   const std::string& expected) {
  if (ok) return;
  std::ostringstream text;
  text.precision(17);
  text << model.name() << ": " << name << " must be " << expected << ", got " << value;
  throw std::invalid_argument(text.str());
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
