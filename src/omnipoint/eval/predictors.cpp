#include "omnipoint/eval/predictors.h"

#include <ATen/ATen.h>
#include <torch/csrc/autograd/grad_mode.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "omnipoint/geometry/points.h"
#include "omnipoint/model/moge2_infer.h"

namespace omnipoint::eval {

namespace {

int64_t tokens_for(const data::Sample& sample, int64_t num_tokens, int64_t patch_size) {
  if (num_tokens > 0) return num_tokens;
  const int64_t area = sample.image.size(0) * sample.image.size(1);
  return std::max<int64_t>(1, (area + patch_size * patch_size / 2) / (patch_size * patch_size));
}

at::Tensor image_batch(const data::Sample& sample, at::Device device) {
  return sample.image.permute({2, 0, 1}).unsqueeze(0).to(device, at::kFloat).contiguous();
}

}  // namespace

GeometryPrediction prediction_from_points(const at::Tensor& points, bool is_metric) {
  const geometry::RaysAndDistance factored = geometry::rays_from_points(points);
  GeometryPrediction prediction;
  prediction.rays = factored.rays;
  prediction.distance = factored.distance;
  prediction.is_metric = is_metric;
  return prediction;
}

Predictor omnipoint_predictor(model::OmniPointModel model, const std::string& name,
                              int64_t num_tokens, at::Device device) {
  model->to(device);
  model->eval();
  const int64_t patch = model->config().encoder.backbone_config.patch_size;
  Predictor predictor;
  predictor.name = name;
  predictor.accepts_intrinsics = true;
  predictor.accepts_sparse_depth = true;
  predictor.predict = [model, num_tokens, device, patch](const EvalSample& item,
                                                         const Conditions& conditions) mutable {
    torch::NoGradGuard no_grad;
    model::OmniPointInputs inputs;
    inputs.image = image_batch(item.sample, device);
    if (conditions.rays.defined())
      inputs.rays = conditions.rays.permute({2, 0, 1}).unsqueeze(0).to(device);
    if (conditions.sparse_depth.defined())
      inputs.sparse_depth = conditions.sparse_depth.unsqueeze(0).to(device);
    model::OmniPointOutput output =
        model->forward(inputs, tokens_for(item.sample, num_tokens, patch));
    if (inputs.sparse_depth.defined() && item.sample.metric)
      output = model::align_to_metric_sparse_depth(output, inputs.sparse_depth);
    GeometryPrediction prediction;
    // A known camera is used as it is (as `omnipoint predict --camera` does): its rays carry
    // the predicted distances; the ray head's output only stands in for an unknown camera.
    prediction.rays = conditions.rays.defined() ? conditions.rays.to(at::kCPU, at::kFloat)
                                                : output.rays[0].to(at::kCPU, at::kFloat);
    prediction.distance = output.distance[0].to(at::kCPU, at::kFloat);
    prediction.metric_scale = output.metric_scale[0].item<double>();
    prediction.is_metric = true;
    return prediction;
  };
  return predictor;
}

Predictor moge2_predictor(model::MoGe2Model model, const std::string& name, int64_t num_tokens,
                          at::Device device) {
  model->to(device);
  model->eval();
  const int64_t patch = model->config().encoder.backbone_config.patch_size;
  Predictor predictor;
  predictor.name = name;
  predictor.predict = [model, num_tokens, device, patch](const EvalSample& item,
                                                         const Conditions&) mutable {
    torch::NoGradGuard no_grad;
    model::MoGe2InferOptions options;
    options.apply_mask = false;  // the protocol scores every GT-valid pixel
    const model::MoGe2Inference inference =
        model::infer(model, image_batch(item.sample, device),
                     tokens_for(item.sample, num_tokens, patch), options);
    GeometryPrediction prediction;
    prediction.rays = inference.rays[0].to(at::kCPU, at::kFloat);
    prediction.distance = inference.distance[0].to(at::kCPU, at::kFloat);
    prediction.is_metric = inference.metric_scale.defined();
    return prediction;
  };
  return predictor;
}

Predictor point_map_predictor(const std::string& name,
                              std::function<at::Tensor(const EvalSample&)> load) {
  Predictor predictor;
  predictor.name = name;
  predictor.predict = [load](const EvalSample& item, const Conditions&) {
    return prediction_from_points(load(item).to(at::kFloat), true);
  };
  return predictor;
}

Predictor oracle_predictor() {
  Predictor predictor;
  predictor.name = "oracle (GT rays and distances)";
  predictor.accepts_intrinsics = true;
  predictor.accepts_sparse_depth = true;
  predictor.predict = [](const EvalSample& item, const Conditions&) {
    GeometryPrediction prediction;
    prediction.rays = item.sample.camera.ray_map(at::kFloat).rays;
    prediction.distance = item.sample.distance;
    prediction.is_metric = item.sample.metric;
    return prediction;
  };
  return predictor;
}

Predictor constant_distance_predictor(double distance) {
  if (!(distance > 0) || !std::isfinite(distance))
    throw std::invalid_argument("constant distance " + std::to_string(distance) +
                                ": expected > 0 metres");
  Predictor predictor;
  char label[64];
  std::snprintf(label, sizeof label, "constant distance %g m (GT rays)", distance);
  predictor.name = label;
  predictor.accepts_intrinsics = true;
  predictor.accepts_sparse_depth = true;
  predictor.predict = [distance](const EvalSample& item, const Conditions& conditions) {
    double value = distance;
    if (conditions.sparse_depth.defined()) {
      const at::Tensor samples = conditions.sparse_depth.masked_select(conditions.sparse_depth > 0);
      if (samples.numel() > 0) value = samples.median().item<double>();
    }
    GeometryPrediction prediction;
    prediction.rays = item.sample.camera.ray_map(at::kFloat).rays;
    prediction.distance = at::full_like(item.sample.distance, value);
    prediction.is_metric = true;
    return prediction;
  };
  return predictor;
}

}  // namespace omnipoint::eval
