#include "omnipoint/geometry/sparse_depth.h"

#include <ATen/ATen.h>
#include <c10/core/GradMode.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace omnipoint::geometry {
namespace {

// Upper bound on the (samples × offsets) elements materialised at once, so that dense
// inputs (every pixel a sample) stay within a few hundred MB.
constexpr std::int64_t kMaxPairsPerPass = std::int64_t{1} << 22;

void check_inputs(const at::Tensor& sparse, const at::Tensor& valid, const SplatOptions& options) {
  if (!sparse.defined() || sparse.dim() < 2 || !at::isFloatingType(sparse.scalar_type())) {
    throw std::invalid_argument(
        "splat_sparse_depth: sparse depth must be a floating tensor of shape (..., H, W)");
  }
  if (valid.defined() && (valid.scalar_type() != at::kBool || valid.sizes() != sparse.sizes())) {
    throw std::invalid_argument(
        "splat_sparse_depth: the validity mask must be a bool tensor of the depth's shape");
  }
  if (options.radius < 0 || !(options.sigma_per_depth > 0) ||
      !std::isfinite(options.sigma_per_depth) || !(options.min_sigma > 0) ||
      !std::isfinite(options.min_sigma)) {
    throw std::invalid_argument(
        "splat_sparse_depth: expected radius >= 0 and finite sigma_per_depth, min_sigma > 0");
  }
}

// The kernel's offsets (Δv, Δu) inside the disc of radius r, as two int64 tensors.
std::pair<at::Tensor, at::Tensor> disc_offsets(std::int64_t radius, const at::Device& device) {
  std::vector<std::int64_t> rows, cols;
  for (std::int64_t dv = -radius; dv <= radius; ++dv) {
    for (std::int64_t du = -radius; du <= radius; ++du) {
      if (du * du + dv * dv <= radius * radius) {
        rows.push_back(dv);
        cols.push_back(du);
      }
    }
  }
  const auto make = [&](const std::vector<std::int64_t>& v) {
    return at::tensor(v, at::kLong).to(device);
  };
  return {make(rows), make(cols)};
}

}  // namespace

SplattedDepth splat_sparse_depth(const at::Tensor& sparse, const at::Tensor& valid,
                                 const SplatOptions& options) {
  check_inputs(sparse, valid, options);
  c10::NoGradGuard no_grad;
  const auto shape = sparse.sizes().vec();
  const std::int64_t height = shape[shape.size() - 2];
  const std::int64_t width = shape[shape.size() - 1];
  const std::int64_t pixels = height * width;
  const std::int64_t batch = pixels > 0 ? sparse.numel() / pixels : 0;
  const auto batch_shape = std::vector<std::int64_t>(shape.begin(), shape.end() - 2);

  const at::Tensor depth = sparse.reshape({batch, height, width});
  at::Tensor samples = valid.defined() ? valid.reshape({batch, height, width}) : depth != 0;
  samples = samples.logical_and(at::isfinite(depth));
  const at::Tensor zeros = at::zeros_like(depth);
  const at::Tensor kept = at::where(samples, depth, zeros);

  // Per-item normalisation by the mean magnitude of the valid values (1 for empty items).
  const at::Tensor count = samples.sum({1, 2}).to(depth.scalar_type());
  const at::Tensor magnitude = kept.abs().sum({1, 2});
  const at::Tensor scale =
      at::where(magnitude > 0, magnitude / count.clamp_min(1), at::ones_like(magnitude));
  const at::Tensor normalised = kept / scale.view({batch, 1, 1});

  const at::Tensor index = samples.nonzero();  // (N, 3): item, row, col
  const at::Tensor item = index.select(1, 0);
  const at::Tensor row = index.select(1, 1);
  const at::Tensor col = index.select(1, 2);
  const at::Tensor value = normalised.index({item, row, col});
  const double max_sigma = std::max(static_cast<double>(options.radius), options.min_sigma);
  const at::Tensor sigma =
      (value.abs() * options.sigma_per_depth).clamp(options.min_sigma, max_sigma);
  const at::Tensor inverse_two_sigma2 = (0.5 / (sigma * sigma)).unsqueeze(1);

  const auto [offset_rows, offset_cols] = disc_offsets(options.radius, depth.device());
  const std::int64_t num_samples = index.size(0);
  const std::int64_t num_offsets = offset_rows.size(0);
  const std::int64_t per_pass =
      std::max<std::int64_t>(1, kMaxPairsPerPass / std::max<std::int64_t>(num_samples, 1));

  at::Tensor numerator = at::zeros({batch * pixels}, depth.options());
  at::Tensor denominator = at::zeros({batch * pixels}, depth.options());
  const at::Tensor item_base = (item * pixels).unsqueeze(1);
  for (std::int64_t begin = 0; num_samples > 0 && begin < num_offsets; begin += per_pass) {
    const std::int64_t end = std::min(begin + per_pass, num_offsets);
    const at::Tensor dv = offset_rows.slice(0, begin, end).unsqueeze(0);
    const at::Tensor du = offset_cols.slice(0, begin, end).unsqueeze(0);
    const at::Tensor target_row = row.unsqueeze(1) + dv;  // (N, k)
    const at::Tensor target_col = col.unsqueeze(1) + du;
    const at::Tensor inside =
        (target_row >= 0) & (target_row < height) & (target_col >= 0) & (target_col < width);
    const at::Tensor target =
        item_base + target_row.clamp(0, height - 1) * width + target_col.clamp(0, width - 1);
    const at::Tensor squared = (du * du + dv * dv).to(depth.scalar_type());
    const at::Tensor weight =
        at::exp(-squared * inverse_two_sigma2) * inside.to(depth.scalar_type());
    numerator.index_add_(0, target.reshape(-1), (weight * value.unsqueeze(1)).reshape(-1));
    denominator.index_add_(0, target.reshape(-1), weight.reshape(-1));
  }

  const at::Tensor covered = denominator > 0;
  const at::Tensor smooth =
      at::where(covered, numerator / at::where(covered, denominator, at::ones_like(denominator)),
                at::zeros_like(numerator));
  auto image_shape = batch_shape;
  image_shape.push_back(height);
  image_shape.push_back(width);
  return {smooth.reshape(image_shape), samples.to(depth.scalar_type()).reshape(image_shape),
          covered.reshape(image_shape), scale.reshape(batch_shape)};
}

}  // namespace omnipoint::geometry
