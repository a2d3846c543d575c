#include "omnipoint/infer/teacher.h"

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>

#include "omnipoint/model/moge2_infer.h"

namespace omnipoint::infer {
namespace {

// (h, w, 3) in [0, 1] -> (1, 3, h, w) on the model's device and dtype.
at::Tensor model_input(const at::Tensor& image, const at::TensorOptions& options) {
  return image.permute({2, 0, 1}).unsqueeze(0).to(options).contiguous();
}

}  // namespace

augment::Teacher omnipoint_teacher(model::OmniPointModel model, int64_t num_tokens,
                                   bool use_intrinsics) {
  return [model, num_tokens, use_intrinsics](const at::Tensor& image,
                                             const camera::Camera& camera) mutable {
    c10::InferenceMode inference;
    const at::Tensor reference = model->parameters().front();
    model::OmniPointInputs inputs;
    inputs.image = model_input(image, reference.options());
    if (use_intrinsics)
      inputs.rays = camera.ray_map(reference.options()).rays.permute({2, 0, 1}).unsqueeze(0);
    const model::OmniPointOutput out = model->forward(inputs, num_tokens);
    const auto back = image.options();
    augment::TeacherPrediction prediction;
    prediction.rays = out.rays.squeeze(0).to(back);
    prediction.distance = out.points.squeeze(0).norm(2, -1).to(back);
    prediction.confident =
        (out.mask.squeeze(0) > 0.5).to(image.device()) & at::isfinite(prediction.distance);
    return prediction;
  };
}

augment::Teacher moge2_teacher(model::MoGe2Model model, int64_t num_tokens) {
  return [model, num_tokens](const at::Tensor& image, const camera::Camera&) mutable {
    const at::Tensor reference = model->parameters().front();
    const model::MoGe2Inference out =
        model::infer(model, model_input(image, reference.options()), num_tokens);
    const auto back = image.options();
    augment::TeacherPrediction prediction;
    prediction.rays = out.rays.squeeze(0).to(back);
    const at::Tensor distance = out.distance.squeeze(0).to(back);
    prediction.confident =
        out.mask.squeeze(0).to(image.device()) & at::isfinite(distance) & (distance > 0);
    prediction.distance = at::where(prediction.confident, distance, at::zeros_like(distance));
    return prediction;
  };
}

}  // namespace omnipoint::infer
