#include "omnipoint/model/moge2_infer.h"

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>

#include <limits>

#include "omnipoint/geometry/points.h"

namespace omnipoint::model {

MoGe2Inference postprocess(const MoGe2Output& output, const MoGe2InferOptions& options) {
  const at::Tensor& affine = output.points;
  const int64_t height = affine.size(1), width = affine.size(2);
  const double aspect = static_cast<double>(width) / static_cast<double>(height);
  MoGe2Inference result;

  at::Tensor mask = output.mask.defined() ? output.mask > 0.5 : at::Tensor();
  const geometry::FocalShift camera =
      geometry::recover_focal_shift(affine, mask, options.focal_shift);
  result.intrinsics = geometry::intrinsics_from_focal(camera.focal, aspect);

  const at::Tensor depth = affine.select(3, 2) + camera.shift.view({-1, 1, 1});
  mask = mask.defined() ? mask & (depth > 0) : depth > 0;
  at::Tensor points = options.force_projection
                          ? geometry::depth_to_points(depth, result.intrinsics)
                          : at::cat({affine.narrow(3, 0, 2), depth.unsqueeze(3)}, 3);
  result.depth = depth;
  if (output.metric_scale.defined()) {
    points = points * output.metric_scale.view({-1, 1, 1, 1});
    result.depth = depth * output.metric_scale.view({-1, 1, 1});
    result.metric_scale = output.metric_scale;
  }
  geometry::RaysAndDistance rays = geometry::rays_from_points(points);
  result.rays = rays.rays;
  result.distance = rays.distance;
  result.points = points;
  if (output.normal.defined()) result.normal = output.normal;
  if (options.apply_mask) {
    const double inf = std::numeric_limits<double>::infinity();
    result.points = at::where(mask.unsqueeze(3), points, inf);
    result.depth = at::where(mask, result.depth, inf);
    result.distance = at::where(mask, result.distance, inf);
    if (result.normal.defined()) result.normal = at::where(mask.unsqueeze(3), result.normal, 0.0);
  }
  result.mask = mask;
  return result;
}

MoGe2Inference infer(MoGe2Model& model, const at::Tensor& image, int64_t num_tokens,
                     const MoGe2InferOptions& options) {
  c10::InferenceMode inference;
  return postprocess(model->forward(image, num_tokens), options);
}

}  // namespace omnipoint::model
