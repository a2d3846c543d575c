#include "omnipoint/geometry/view_plane_uv.h"

#include <ATen/ATen.h>

#include <cmath>
#include <stdexcept>

namespace omnipoint::geometry {

at::Tensor normalized_view_plane_uv(int64_t width, int64_t height, double aspect_ratio,
                                    const at::TensorOptions& options) {
  if (width <= 0 || height <= 0 || !(aspect_ratio > 0) || !std::isfinite(aspect_ratio))
    throw std::invalid_argument(
        "view-plane uv needs width, height > 0 and a positive finite aspect ratio");
  const double diagonal = std::sqrt(1.0 + aspect_ratio * aspect_ratio);
  const double span_u =
      aspect_ratio / diagonal * static_cast<double>(width - 1) / static_cast<double>(width);
  const double span_v =
      1.0 / diagonal * static_cast<double>(height - 1) / static_cast<double>(height);
  const at::Tensor u = at::linspace(-span_u, span_u, width, options);
  const at::Tensor v = at::linspace(-span_v, span_v, height, options);
  return at::stack({u.expand({height, width}), v.unsqueeze(1).expand({height, width})}, -1);
}

}  // namespace omnipoint::geometry
