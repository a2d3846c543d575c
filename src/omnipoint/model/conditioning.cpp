#include "omnipoint/model/conditioning.h"

#include <ATen/ATen.h>
#include <torch/nn/init.h>

#include <stdexcept>
#include <string>

#include "omnipoint/geometry/sparse_depth.h"

namespace omnipoint::model {
namespace {

void check_sparse_depth(const at::Tensor& sparse_depth) {
  if (!sparse_depth.defined() || sparse_depth.dim() != 3 || !sparse_depth.is_floating_point()) {
    throw std::invalid_argument(
        "sparse depth: expected a floating-point (B,H,W) tensor of radial distances");
  }
}

}  // namespace

at::Tensor rays_present(const at::Tensor& rays) {
  if (!rays.defined() || rays.dim() != 4 || rays.size(1) != 3 || !rays.is_floating_point()) {
    throw std::invalid_argument("ray map: expected a floating-point (B,3,H,W) tensor");
  }
  return valid_rays(rays).ne(0).flatten(1).any(1);
}

at::Tensor valid_rays(const at::Tensor& rays) {
  const at::Tensor finite = at::isfinite(rays).all(1, /*keepdim=*/true);
  return at::where(finite, rays, at::zeros_like(rays));
}

at::Tensor sparse_depth_valid(const at::Tensor& sparse_depth) {
  check_sparse_depth(sparse_depth);
  return at::isfinite(sparse_depth).logical_and(sparse_depth > 0);
}

at::Tensor sparse_depth_present(const at::Tensor& sparse_depth) {
  return sparse_depth_valid(sparse_depth).flatten(1).any(1);
}

torch::nn::Embedding make_state_embedding(int64_t embed_dim) {
  torch::nn::Embedding embedding(2, embed_dim);
  torch::nn::init::zeros_(embedding->weight);
  return embedding;
}

at::Tensor state_embedding(torch::nn::Embedding& embedding, const at::Tensor& present) {
  return embedding->forward(present.to(at::kLong)).unsqueeze(1);
}

ConditionEncoderImpl::ConditionEncoderImpl(int64_t in_channels, int64_t hidden_dim,
                                           int64_t embed_dim, int64_t patch_size) {
  patchify = register_module(
      "patchify",
      Conv2d(torch::nn::Conv2dOptions(in_channels, hidden_dim, patch_size).stride(patch_size)));
  fuse = register_module("fuse", Conv2d(torch::nn::Conv2dOptions(hidden_dim, embed_dim, 1)));
  torch::nn::init::zeros_(fuse->weight);
  torch::nn::init::zeros_(fuse->bias);
}

at::Tensor ConditionEncoderImpl::forward(const at::Tensor& x) {
  const at::Tensor features = fuse->forward(at::gelu(patchify->forward(x)));
  return features.flatten(2).transpose(1, 2);  // (B, rows·cols, C)
}

at::Tensor sparse_depth_features(const at::Tensor& sparse_depth, int64_t height, int64_t width,
                                 const ConditioningConfig& config) {
  const at::Tensor valid = sparse_depth_valid(sparse_depth);
  const int64_t batch = sparse_depth.size(0);
  const int64_t in_height = sparse_depth.size(1);
  const int64_t in_width = sparse_depth.size(2);
  // Grid pixel holding each input pixel centre: floor((i + 0.5) · h / H).
  const auto long_options = sparse_depth.options().dtype(at::kLong);
  const at::Tensor rows =
      at::div((at::arange(in_height, long_options) * 2 + 1) * height, 2 * in_height, "floor");
  const at::Tensor cols =
      at::div((at::arange(in_width, long_options) * 2 + 1) * width, 2 * in_width, "floor");
  const at::Tensor target = (rows.unsqueeze(1) * width + cols.unsqueeze(0)).flatten();
  const at::Tensor index = target.unsqueeze(0).expand({batch, target.size(0)});

  const at::Tensor values = at::where(valid, sparse_depth, at::zeros_like(sparse_depth)).flatten(1);
  const at::Tensor counts = valid.to(sparse_depth.scalar_type()).flatten(1);
  const at::Tensor grid_sum =
      at::zeros({batch, height * width}, sparse_depth.options()).scatter_add_(1, index, values);
  const at::Tensor grid_count =
      at::zeros({batch, height * width}, sparse_depth.options()).scatter_add_(1, index, counts);
  const at::Tensor grid_valid = (grid_count > 0).view({batch, height, width});
  const at::Tensor grid_depth = (grid_sum / grid_count.clamp_min(1)).view({batch, height, width});

  geometry::SplatOptions options;
  options.radius = config.gaussian_smoothing ? config.splat_radius : 0;
  options.sigma_per_depth = config.splat_sigma_per_depth;
  options.min_sigma = config.splat_min_sigma;
  const geometry::SplattedDepth splatted =
      geometry::splat_sparse_depth(grid_depth, grid_valid, options);
  return at::stack({splatted.smooth, splatted.mask}, 1);
}

}  // namespace omnipoint::model
