// infer::run: the network of either format with the known conditions, then the metric
// alignment to the sparse depth.
#include "omnipoint/infer/infer.h"

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/camera/camera_info.h"
#include "omnipoint/geometry/alignment.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/infer/teacher.h"
#include "omnipoint/io/torch_checkpoint.h"
#include "omnipoint/model/moge2_infer.h"
#include "omnipoint/model/omnipoint_weights.h"

namespace omnipoint::infer {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The network's geometry of a batch before the alignment.
struct Geometry {
  at::Tensor rays, distance, mask, metric_scale;
  bool metric = false;
};

Geometry run_omnipoint(const Network& network, const at::Tensor& images,
                       const at::Tensor& camera_rays, const at::Tensor& sparse,
                       int64_t num_tokens) {
  // A condition goes in where the model has its branch; sparse depth still aligns the scale.
  model::OmniPointModel omnipoint = network.omnipoint();
  const model::ConditioningConfig& branches = omnipoint->config().conditioning;
  model::OmniPointInputs inputs;
  inputs.image = images;
  if (camera_rays.defined() && branches.intrinsics)
    inputs.rays = camera_rays.permute({0, 3, 1, 2}).contiguous();
  if (branches.sparse_depth) inputs.sparse_depth = sparse;
  const model::OmniPointOutput out = omnipoint->forward(inputs, num_tokens);
  return {out.rays, out.distance, out.mask > 0.5, out.metric_scale, true};
}

// MoGe's infer() without its mask applied and without the metric scale multiplied in, so the
// distances stay scale-invariant.
Geometry run_moge2(const Network& network, const at::Tensor& images, int64_t num_tokens) {
  model::MoGe2Output output = network.moge2()->forward(images, num_tokens);
  const at::Tensor scale = output.metric_scale;
  output.metric_scale = at::Tensor();
  model::MoGe2InferOptions options;
  options.apply_mask = false;
  const model::MoGe2Inference out = model::postprocess(output, options);
  return {out.rays, out.distance, out.mask,
          scale.defined() ? scale : at::ones({images.size(0)}, images.options()), scale.defined()};
}

// MoGe-2 on a wide camera: pinhole views tiling its field of view, each predicted (as a
// pinhole image, by run) and merged scale-consistently; the merged distances are the
// views' metric ones.
Geometry run_multi_view(const Network& network, const at::Tensor& images,
                        const camera::Camera& camera, const at::Tensor& camera_rays,
                        int64_t num_tokens) {
  const augment::Teacher view_teacher = teacher(network, num_tokens, /*use_intrinsics=*/false);
  std::vector<at::Tensor> distances, masks;
  for (int64_t b = 0; b < images.size(0); ++b) {
    const augment::MergedPrediction merged =
        augment::predict_wide_from_views(camera, images[b].permute({1, 2, 0}), view_teacher);
    distances.push_back(merged.distance.to(images.options()));
    masks.push_back(merged.mask.to(images.device()));
  }
  return {camera_rays, at::stack(distances), at::stack(masks),
          at::ones({images.size(0)}, images.options()),
          !network.moge2()->config().scale_head_dims.empty()};
}

}  // namespace

Network::Network(model::OmniPointModel model, at::Device device)
    : format_("omnipoint"),
      device_(device),
      default_num_tokens_(model->config().num_tokens_range[1]),
      omnipoint_(std::move(model)) {
  omnipoint_->eval();
  omnipoint_->to(device);
}

Network::Network(model::MoGe2Model model, at::Device device)
    : format_("moge2"),
      device_(device),
      default_num_tokens_(model->config().default_num_tokens()),
      moge2_(std::move(model)) {
  moge2_->eval();
  moge2_->to(device);
}

namespace {

// MoGe-1's config names its encoder by a string (MoGe-2's is a dict): another network.
bool is_moge1_config(const std::string& config_json) {
  const nlohmann::json config = nlohmann::json::parse(config_json, nullptr, false);
  return config.is_object() && config.contains("encoder") && config["encoder"].is_string();
}

}  // namespace

Network load_network(const std::string& path, at::Device device) {
  // io reports an unreadable file with its path; what the content lacks gets the path here.
  const io::WeightsFile file = io::read_weights(path);
  const auto format = file.metadata.find("format");
  const std::string kind = format == file.metadata.end() ? "moge2" : format->second;
  try {
    if (kind == "omnipoint")
      return Network(model::load_omnipoint_model(file.tensors, file.metadata), device);
    if (kind == "state_dict")
      throw std::invalid_argument(
          "a bare state dict without a model config (e.g. DINOv2's backbone weights): not a "
          "model to run; it can initialise training (init.from \"dinov2\", init.path)");
    if (kind != "moge2")
      throw std::invalid_argument("unknown metadata format \"" + kind +
                                  "\" (expected \"omnipoint\" or \"moge2\")");
    const auto config = file.metadata.find("config");
    if (config == file.metadata.end())
      throw std::invalid_argument(
          "expected an OmniPoint or MoGe-2 checkpoint (safetensors with a \"config\" metadata "
          "entry), found no config");
    if (is_moge1_config(config->second))
      throw std::invalid_argument(
          "a MoGe-1 checkpoint: this tool runs MoGe-2 and OmniPoint networks (MoGe-1's DINOv2 "
          "backbone can initialise training: init.from \"dinov2\", init.path)");
    return Network(model::load_moge2(file.tensors, file.metadata), device);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("model " + path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("model " + path + ": " + e.what());
  }
}

namespace {

// run() up to the metric scale: the network (under the precision's autocast) and the
// alignment.
Result run_network(const Network& network, const Inputs& inputs) {
  const at::Tensor& given = inputs.images;
  if (!given.defined() || given.dim() != 4 || given.size(1) != 3 || given.size(2) < 1 ||
      given.size(3) < 1)
    throw std::invalid_argument("infer: expected images (B, 3, H, W), got " +
                                (given.defined() ? c10::str(given.sizes()) : "none"));
  const at::Tensor images = given.to(network.device(), at::kFloat).contiguous();
  const int64_t batch = images.size(0), height = images.size(2), width = images.size(3);
  const int64_t num_tokens = network.num_tokens(inputs.num_tokens);
  Result result;

  at::Tensor camera_rays, camera_valid;
  const bool wide =
      inputs.camera && camera::camera_class(*inputs.camera) != camera::CameraClass::kPerspective;
  if (inputs.camera) {
    if (inputs.camera->width() != width || inputs.camera->height() != height)
      throw std::invalid_argument("infer: the camera is " + std::to_string(inputs.camera->width()) +
                                  "x" + std::to_string(inputs.camera->height()) +
                                  " but the images are " + std::to_string(width) + "x" +
                                  std::to_string(height));
    const camera::Rays ray_map = inputs.camera->ray_map(images.options());
    camera_rays = ray_map.rays.unsqueeze(0).expand({batch, height, width, 3});
    camera_valid = ray_map.valid.unsqueeze(0);
  }
  at::Tensor sparse;
  if (inputs.sparse_distance.defined()) {
    if (inputs.sparse_distance.sizes() != at::IntArrayRef{batch, height, width})
      throw std::invalid_argument("infer: the sparse distances must be (B, H, W) = (" +
                                  std::to_string(batch) + ", " + std::to_string(height) + ", " +
                                  std::to_string(width) + "), got " +
                                  c10::str(inputs.sparse_distance.sizes()));
    sparse = inputs.sparse_distance.to(images.options());
    sparse = at::where(at::isfinite(sparse) & (sparse > 0), sparse, at::zeros_like(sparse));
  }

  auto start = Clock::now();
  Geometry net;
  const model::AutocastScope autocast(inputs.precision, network.device().type());
  if (network.omnipoint()) {
    net = run_omnipoint(network, images, camera_rays, sparse, num_tokens);
  } else {
    result.multi_view = wide;
    if (inputs.camera)
      result.notes.emplace_back(
          wide ? "MoGe-2 checkpoint on a wide camera: multi-view mode (pinhole views tiling the "
                 "field of view, predicted and merged)"
               : "MoGe-2 checkpoint: the camera is not a network input (pinhole model)");
    if (sparse.defined())
      result.notes.emplace_back("MoGe-2 checkpoint: the sparse depth only aligns the metric scale");
    net = wide ? run_multi_view(network, images, *inputs.camera, camera_rays, num_tokens)
               : run_moge2(network, images, num_tokens);
  }
  result.timing.network_ms = ms_since(start);

  // A given camera is used as it is: its rays carry the predicted distances (pixels outside
  // its domain are invalid); the predicted rays stand in only for an unknown camera.
  result.rays = camera_rays.defined() ? camera_rays : net.rays;
  if (camera_rays.defined() && !result.multi_view) result.predicted_rays = net.rays;
  result.distance = net.distance;
  result.mask = net.mask & at::isfinite(net.distance) & (net.distance > 0);
  if (camera_valid.defined()) result.mask = result.mask & camera_valid;
  result.metric = net.metric;

  start = Clock::now();
  at::Tensor scale = net.metric_scale;
  result.alignment_factor = at::ones_like(scale);
  result.sparse_samples = at::zeros({batch}, scale.options().dtype(at::kLong));
  if (sparse.defined()) {
    const at::Tensor usable = (sparse > 0) & result.mask;
    result.sparse_samples = usable.flatten(1).sum(1);
    if (inputs.align_to_sparse_depth) {
      result.alignment_factor =
          geometry::fit_scale_to_sparse_depth((scale.view({batch, 1, 1}) * net.distance).flatten(1),
                                              sparse.flatten(1), usable.flatten(1));
      scale = scale * result.alignment_factor;
      result.aligned = true;
      result.metric = result.metric || (result.sparse_samples > 0).all().item<bool>();
    }
  }
  result.timing.alignment_ms = ms_since(start);
  result.metric_scale = scale;
  return result;
}

}  // namespace

Result run(const Network& network, const Inputs& inputs) {
  c10::InferenceMode inference;
  Result result = run_network(network, inputs);
  // Outside the network's autocast: the shipped geometry is computed in fp32.
  const at::Tensor scale = result.metric_scale.view({result.metric_scale.size(0), 1, 1});
  result.shipped = point_map(result.rays, scale * result.distance, result.mask);
  return result;
}

PointMap point_map(const at::Tensor& rays, const at::Tensor& distance, const at::Tensor& mask) {
  PointMap map;
  map.mask =
      mask.to(at::kBool) & at::isfinite(distance) & (distance > 0) & (rays.norm(2, -1) > 0.5);
  map.rays = at::where(at::isfinite(rays), rays, at::zeros_like(rays));
  map.distance = at::where(map.mask, distance, at::zeros_like(distance));
  map.points = geometry::points_from_rays(map.rays, map.distance);
  return map;
}

RawOutput forward(const Network& network, const at::Tensor& images, int64_t num_tokens,
                  model::Precision precision) {
  c10::InferenceMode inference;
  const model::AutocastScope autocast(precision, network.device().type());
  const at::Tensor input = images.to(network.device(), at::kFloat).contiguous();
  const int64_t tokens = network.num_tokens(num_tokens);
  if (network.omnipoint()) {
    const model::OmniPointOutput out = network.omnipoint()->forward({input, {}, {}}, tokens);
    return {out.points, out.mask, out.metric_scale, out.rays, out.distance, {}};
  }
  const model::MoGe2Output out = network.moge2()->forward(input, tokens);
  const geometry::RaysAndDistance rays = geometry::rays_from_points(out.points);
  return {out.points, out.mask, out.metric_scale, rays.rays, rays.distance, out.normal};
}

}  // namespace omnipoint::infer
