#include "omnipoint/model/omnipoint_model.h"

#include <ATen/ATen.h>
#include <torch/nn/functional/upsampling.h>

#include <stdexcept>
#include <string>

#include "omnipoint/geometry/points.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::model {
namespace {

namespace F = torch::nn::functional;

void check_inputs(const OmniPointInputs& inputs) {
  const at::Tensor& image = inputs.image;
  if (!image.defined() || image.dim() != 4 || image.size(1) != 3 || !image.is_floating_point())
    throw std::invalid_argument(
        "OmniPoint input image: expected a floating-point (B,3,H,W) tensor");
  const int64_t batch = image.size(0);
  if (inputs.rays.defined() && (inputs.rays.dim() != 4 || inputs.rays.size(0) != batch))
    throw std::invalid_argument(
        "OmniPoint ray map: expected (B,3,H,W) with the image's batch size " +
        std::to_string(batch));
  if (inputs.sparse_depth.defined() &&
      (inputs.sparse_depth.dim() != 3 || inputs.sparse_depth.size(0) != batch))
    throw std::invalid_argument(
        "OmniPoint sparse depth: expected (B,H,W) with the image's batch size " +
        std::to_string(batch));
}

// (B,C,h,w) head output at the image size, channels last.
at::Tensor head_map(ConvStack& head, const std::vector<at::Tensor>& neck_levels,
                    const at::Tensor& image) {
  return resize_to_image_channels_last(head->forward(neck_levels).back(), image);
}

at::Tensor unit_length(const at::Tensor& vectors) {
  return vectors / at::linalg_vector_norm(vectors, 2, {-1}, true).clamp_min(1e-12);
}

}  // namespace

OmniPointModelImpl::OmniPointModelImpl(const OmniPointConfig& config) : config_(config) {
  util::use_default_threads();  // its operators on every core (util/threads.h)
  config_.validate();
  encoder = register_module("encoder", MoGe2Encoder(config_.encoder));
  neck = register_module("neck", ConvStack(config_.neck));
  if (config_.output == OutputKind::kRayDistance) {
    ray_head = register_module("ray_head", ConvStack(config_.ray_head));
    distance_head = register_module("distance_head", ConvStack(config_.distance_head));
  } else {
    points_head = register_module("points_head", ConvStack(config_.points_head));
  }
  mask_head = register_module("mask_head", ConvStack(config_.mask_head));
  scale_head = register_module("scale_head", scale_mlp(config_.scale_head_dims));

  const ConditioningConfig& conditioning = config_.conditioning;
  const DinoV2Config& vit = config_.encoder.backbone_config;
  if (conditioning.intrinsics) {
    intrinsics_encoder = register_module(
        "intrinsics_encoder",
        ConditionEncoder(3, conditioning.encoder_dim, vit.embed_dim, vit.patch_size));
    if (conditioning.state_embeddings)
      intrinsics_state = register_module("intrinsics_state", make_state_embedding(vit.embed_dim));
  }
  if (conditioning.sparse_depth) {
    sparse_depth_encoder = register_module(
        "sparse_depth_encoder",
        ConditionEncoder(2, conditioning.encoder_dim, vit.embed_dim, vit.patch_size));
    if (conditioning.state_embeddings)
      depth_state = register_module("depth_state", make_state_embedding(vit.embed_dim));
  }
}

bool is_conditioning_tensor(const std::string& name) {
  for (const char* branch :
       {"intrinsics_encoder.", "intrinsics_state.", "sparse_depth_encoder.", "depth_state."})
    if (name.rfind(branch, 0) == 0) return true;
  return false;
}

OmniPointModelImpl::TokenConditioning OmniPointModelImpl::condition_tokens(
    const OmniPointInputs& inputs, const TokenGrid& grid) {
  check_inputs(inputs);
  const at::Tensor& image = inputs.image;
  const int64_t batch = image.size(0);
  const int64_t patch = config_.encoder.backbone_config.patch_size;
  const int64_t vit_height = grid.rows * patch, vit_width = grid.cols * patch;
  if (inputs.rays.defined() && !intrinsics_encoder)
    throw std::invalid_argument("OmniPoint ray map given, but this model has no intrinsics branch");
  if (inputs.sparse_depth.defined() && !sparse_depth_encoder)
    throw std::invalid_argument(
        "OmniPoint sparse depth given, but this model has no sparse-depth branch");

  TokenConditioning result;
  const at::Tensor none = at::zeros({batch}, image.options().dtype(at::kBool));
  result.intrinsics_present = inputs.rays.defined() ? rays_present(inputs.rays) : none;
  result.sparse_depth_present =
      inputs.sparse_depth.defined() ? sparse_depth_present(inputs.sparse_depth) : none;

  // Patch-token offsets: each branch's encoding where its condition is present, zero elsewhere.
  at::Tensor patch_offset;
  const auto add_where_present = [&](const at::Tensor& encoding, const at::Tensor& present) {
    const at::Tensor masked =
        at::where(present.view({batch, 1, 1}), encoding, at::zeros_like(encoding));
    patch_offset = patch_offset.defined() ? patch_offset + masked : masked;
  };
  if (inputs.rays.defined()) {
    const at::Tensor rays = F::interpolate(valid_rays(inputs.rays.to(image.options())),
                                           F::InterpolateFuncOptions()
                                               .size(std::vector<int64_t>{vit_height, vit_width})
                                               .mode(torch::kBilinear)
                                               .align_corners(false)
                                               .antialias(true));
    add_where_present(intrinsics_encoder->forward(rays), result.intrinsics_present);
  }
  if (inputs.sparse_depth.defined()) {
    const at::Tensor features = sparse_depth_features(inputs.sparse_depth.to(image.options()),
                                                      vit_height, vit_width, config_.conditioning);
    add_where_present(sparse_depth_encoder->forward(features), result.sparse_depth_present);
  }

  // Token-sequence offsets: the state embeddings, on every token (class, registers, patches).
  at::Tensor state_offset;
  if (intrinsics_state) state_offset = state_embedding(intrinsics_state, result.intrinsics_present);
  if (depth_state) {
    const at::Tensor e_depth = state_embedding(depth_state, result.sparse_depth_present);
    state_offset = state_offset.defined() ? state_offset + e_depth : e_depth;
  }

  if (!patch_offset.defined() && !state_offset.defined()) return result;  // exactly MoGe-2's tokens
  const int64_t prefix = encoder->backbone->num_prefix_tokens();
  const int64_t dim = config_.encoder.backbone_config.embed_dim;
  if (!patch_offset.defined())
    patch_offset = at::zeros({batch, grid.rows * grid.cols, dim}, image.options());
  at::Tensor offset = at::cat({at::zeros({batch, prefix, dim}, image.options()), patch_offset}, 1);
  result.offset = state_offset.defined() ? offset + state_offset : offset;
  return result;
}

EncoderOutput OmniPointModelImpl::encode(const OmniPointInputs& inputs, const TokenGrid& grid,
                                         TokenConditioning* conditioning) {
  TokenConditioning conditions = condition_tokens(inputs, grid);
  at::Tensor tokens = encoder->backbone->prepare_tokens(encoder->preprocess(inputs.image, grid));
  if (conditions.offset.defined()) tokens = tokens + conditions.offset;
  EncoderOutput encoded = encoder->project(
      encoder->backbone->intermediate_layers(tokens, config_.encoder.intermediate_layers), grid);
  if (conditioning) *conditioning = std::move(conditions);
  return encoded;
}

OmniPointOutput OmniPointModelImpl::forward(const OmniPointInputs& inputs, int64_t num_tokens) {
  check_inputs(inputs);
  const int64_t batch = inputs.image.size(0), height = inputs.image.size(2),
                width = inputs.image.size(3);
  const TokenGrid grid = token_grid(height, width, num_tokens);
  TokenConditioning conditioning;
  const EncoderOutput encoded = encode(inputs, grid, &conditioning);

  const double aspect = static_cast<double>(width) / static_cast<double>(height);
  const std::vector<at::Tensor> neck_levels =
      neck->forward(neck_inputs(encoded.features, grid, aspect, config_.neck.num_levels()));

  OmniPointOutput out;
  out.intrinsics_present = conditioning.intrinsics_present;
  out.sparse_depth_present = conditioning.sparse_depth_present;
  if (config_.output == OutputKind::kRayDistance) {
    out.ray_raw = head_map(ray_head, neck_levels, inputs.image);
    out.rays = unit_length(out.ray_raw);
    out.log_distance = head_map(distance_head, neck_levels, inputs.image).squeeze(-1);
    out.distance = at::exp(out.log_distance);
  } else {
    out.points_raw = head_map(points_head, neck_levels, inputs.image);
    const geometry::RaysAndDistance factored =
        geometry::rays_from_points(remap_points(out.points_raw, "exp"));
    out.rays = factored.rays;
    out.distance = factored.distance;
  }
  out.mask_logits = head_map(mask_head, neck_levels, inputs.image).squeeze(-1);
  out.mask = at::sigmoid(out.mask_logits);
  out.log_metric_scale =
      log_metric_scale(scale_head, encoded.class_token, inputs.image.scalar_type());
  out.metric_scale = at::exp(out.log_metric_scale);
  out.points = out.metric_scale.view({batch, 1, 1, 1}) * out.distance.unsqueeze(-1) * out.rays;
  return out;
}

}  // namespace omnipoint::model
