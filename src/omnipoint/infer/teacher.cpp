#include "omnipoint/infer/teacher.h"

#include <ATen/ATen.h>

#include <utility>

namespace omnipoint::infer {

augment::Teacher teacher(const Network& network, int64_t num_tokens, bool use_intrinsics) {
  return
      [network, num_tokens, use_intrinsics](const at::Tensor& image, const camera::Camera& camera) {
        Inputs inputs;
        inputs.images = image.permute({2, 0, 1}).unsqueeze(0);  // (h, w, 3) -> (1, 3, h, w)
        if (use_intrinsics && network.omnipoint()) inputs.camera = camera;
        inputs.num_tokens = num_tokens;
        const Result result = run(network, inputs);
        const auto back = image.options();
        augment::TeacherPrediction prediction;
        prediction.rays = result.rays[0].to(back);
        prediction.confident = result.mask[0].to(image.device());
        const at::Tensor distance = (result.metric_scale[0] * result.distance[0]).to(back);
        prediction.distance =
            network.moge2() ? at::where(prediction.confident, distance, at::zeros_like(distance))
                            : distance;
        return prediction;
      };
}

augment::Teacher omnipoint_teacher(model::OmniPointModel model, int64_t num_tokens,
                                   bool use_intrinsics) {
  const at::Device device = model->parameters().front().device();
  return teacher(Network(std::move(model), device), num_tokens, use_intrinsics);
}

augment::Teacher moge2_teacher(model::MoGe2Model model, int64_t num_tokens) {
  const at::Device device = model->parameters().front().device();
  return teacher(Network(std::move(model), device), num_tokens);
}

}  // namespace omnipoint::infer
