#include "omnipoint/train/losses.h"

#include <ATen/ATen.h>

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "omnipoint/geometry/alignment.h"

namespace omnipoint::train {
namespace {

void check_map(const at::Tensor& tensor, int64_t dims, const char* what) {
  if (!tensor.defined() || tensor.dim() != dims)
    throw std::invalid_argument(std::string("training loss: ") + what + " must be a " +
                                std::to_string(dims) + "-D batched tensor");
}

at::Tensor positive_finite(const at::Tensor& scale) {
  return at::isfinite(scale) & (scale > 0);
}

// The angle between vectors (..., 3), atan2(|a×b|, a·b); exact near 0 and π.
at::Tensor angle_between(const at::Tensor& a, const at::Tensor& b) {
  return at::atan2(at::cross(a, b, -1).norm(2, {-1}), (a * b).sum(-1));
}

// MoGe's _smooth: Huber-like below beta.
at::Tensor smooth(const at::Tensor& err, double beta) {
  return at::where(err < beta, 0.5 * err.square() / beta, err - 0.5 * beta);
}

}  // namespace

const std::vector<std::pair<std::string, PointLoss>>& point_loss_names() {
  static const std::vector<std::pair<std::string, PointLoss>> names = {
      {"decoupled", PointLoss::kDecoupled},
      {"naive", PointLoss::kNaive},
      {"disjoint", PointLoss::kDisjoint}};
  return names;
}

PointLoss parse_point_loss(const std::string& name) {
  for (const auto& [text, loss] : point_loss_names())
    if (text == name) return loss;
  throw std::invalid_argument("point loss \"" + name + "\": expected decoupled, naive or disjoint");
}

at::Tensor inverse_distance_weight(const at::Tensor& gt_points, const at::Tensor& mask) {
  const at::Tensor maskf = mask.to(gt_points.scalar_type());
  const at::Tensor weight = maskf / gt_points.norm(2, {-1}).clamp_min(1e-5);
  const at::Tensor mean = weight.sum({-2, -1}, true) / maskf.sum({-2, -1}, true).clamp_min(1.0);
  return at::minimum(weight, 10.0 * mean);
}

at::Tensor alignment_scale(const at::Tensor& pred_points, const at::Tensor& gt_points,
                           const at::Tensor& mask, double trunc) {
  at::NoGradGuard no_grad;
  const int64_t batch = pred_points.size(0);
  const bool points = pred_points.dim() == 4;
  const at::Tensor weight = points ? inverse_distance_weight(gt_points, mask)
                                   : inverse_distance_weight(gt_points.unsqueeze(-1), mask);
  at::Tensor scale;
  if (points) {
    scale = geometry::fit_points_scale_l1(
                pred_points.detach().reshape({batch, -1, 3}), gt_points.reshape({batch, -1, 3}),
                weight.reshape({batch, -1}), mask.reshape({batch, -1}), trunc)
                .scale;
  } else {
    scale = geometry::fit_scale_l1_truncated(
                pred_points.detach().reshape({batch, -1}), gt_points.reshape({batch, -1}),
                weight.reshape({batch, -1}), trunc, mask.reshape({batch, -1}))
                .scale;
  }
  return at::where(positive_finite(scale), scale, at::full_like(scale, NAN));
}

at::Tensor aligned_l1_loss(const at::Tensor& pred, const at::Tensor& gt, const at::Tensor& weight,
                           const at::Tensor& scale) {
  const at::Tensor valid = positive_finite(scale);
  const at::Tensor safe_scale = at::where(valid, scale, at::zeros_like(scale)).detach();
  at::Tensor error;
  if (pred.dim() == 4) {
    error =
        ((safe_scale.view({-1, 1, 1, 1}) * pred - gt).abs() * weight.unsqueeze(-1)).mean({1, 2, 3});
  } else {
    error = ((safe_scale.view({-1, 1, 1}) * pred - gt).abs() * weight).mean({1, 2});
  }
  return at::where(valid, error, at::zeros_like(error));
}

at::Tensor ray_loss(const at::Tensor& pred_rays, const at::Tensor& gt_rays,
                    const at::Tensor& valid) {
  check_map(pred_rays, 4, "predicted rays");
  return ((pred_rays - gt_rays).abs().sum(-1) * valid.to(pred_rays.scalar_type())).mean({1, 2});
}

at::Tensor metric_scale_loss(const at::Tensor& log_pred_scale, const at::Tensor& target_scale,
                             const at::Tensor& metric) {
  const at::Tensor ok = metric.to(at::kBool) & positive_finite(target_scale);
  const at::Tensor target = at::where(ok, target_scale, at::ones_like(target_scale)).log().detach();
  return at::where(ok, (log_pred_scale - target).square(), at::zeros_like(log_pred_scale));
}

at::Tensor gauge_loss(const at::Tensor& distance, const at::Tensor& mask) {
  check_map(distance, 3, "predicted distance");
  const at::Tensor weight = mask.to(distance.scalar_type());
  const at::Tensor count = weight.sum({1, 2});
  const at::Tensor log_distance =
      at::where(mask, distance.clamp_min(1e-12).log(), at::zeros_like(distance));
  const at::Tensor mean = log_distance.sum({1, 2}) / count.clamp_min(1.0);
  return at::where(count > 0, mean.square(), at::zeros_like(mean));
}

at::Tensor sparse_label_factor(const at::Tensor& mask, const at::Tensor& sparse) {
  const auto options = at::TensorOptions().dtype(at::kDouble).device(mask.device());
  if (!sparse.defined()) return at::ones({mask.size(0)}, options);
  const double pixels = static_cast<double>(mask.size(1) * mask.size(2));
  const at::Tensor labelled = mask.sum({1, 2}).to(at::kDouble).clamp_min(1.0);
  return at::where(sparse.to(mask.device()), pixels / labelled, at::ones_like(labelled));
}

at::Tensor normal_loss(const at::Tensor& pred_points, const at::Tensor& gt_points,
                       const at::Tensor& mask, const at::Tensor& sparse) {
  check_map(pred_points, 4, "predicted points");
  const int64_t height = pred_points.size(1), width = pred_points.size(2);
  using at::indexing::Slice;
  const auto corner = [](const at::Tensor& map, int row, int col) {
    return map.index(
        {Slice(), Slice(row, map.size(1) - 1 + row), Slice(col, map.size(2) - 1 + col)});
  };
  const double min_angle = M_PI / 180.0, max_angle = M_PI / 2.0, beta = 3.0 * M_PI / 180.0;
  // MoGe clamps the angle at 1° (no gradient below it); the constant it leaves at a perfect
  // prediction is subtracted, so that a perfect prediction costs zero (same gradients).
  const double floor = 0.5 * min_angle * min_angle / beta;
  // The four triangles of a 2×2 cell (lu, ru, ld, rd), as MoGe: each is the cross product of the
  // edges at one corner, present when its three corners are labelled.
  const auto triangles = [&](const at::Tensor& p) {
    const at::Tensor lu = corner(p, 0, 0), ru = corner(p, 0, 1), ld = corner(p, 1, 0),
                     rd = corner(p, 1, 1);
    return std::vector<at::Tensor>{at::cross(ru - rd, ld - rd, -1), at::cross(lu - ru, rd - ru, -1),
                                   at::cross(ld - lu, ru - lu, -1),
                                   at::cross(rd - ld, lu - ld, -1)};
  };
  const at::Tensor mlu = corner(mask, 0, 0), mru = corner(mask, 0, 1), mld = corner(mask, 1, 0),
                   mrd = corner(mask, 1, 1);
  const std::vector<at::Tensor> masks{mru & mld & mrd, mlu & mrd & mru, mld & mru & mlu,
                                      mrd & mlu & mld};
  const std::vector<at::Tensor> pred = triangles(pred_points), gt = triangles(gt_points);
  at::Tensor loss = at::zeros({pred_points.size(0), height - 1, width - 1}, pred_points.options());
  // Unlabelled triangles get a fixed non-degenerate pair so that no 0/0 reaches the gradient.
  const at::Tensor unit = at::tensor({0.0, 0.0, 1.0}, pred_points.options());
  for (size_t k = 0; k < 4; ++k) {
    const at::Tensor m = masks[k].unsqueeze(-1);
    const at::Tensor angle = angle_between(at::where(m, pred[k], unit), at::where(m, gt[k], unit));
    loss = loss + masks[k].to(loss.scalar_type()) *
                      (smooth(angle.clamp(min_angle, max_angle), beta) - floor);
  }
  at::Tensor per_item = loss.mean({1, 2});
  if (sparse.defined()) {
    // A sparse item: the mean over its cells with a labelled triangle (see the top of losses.h).
    const at::Tensor labelled_cells =
        (masks[0] | masks[1] | masks[2] | masks[3]).sum({1, 2}).to(loss.scalar_type());
    const double cells = static_cast<double>((height - 1) * (width - 1));
    per_item = per_item * at::where(sparse.to(loss.device()), cells / labelled_cells.clamp_min(1.0),
                                    at::ones_like(labelled_cells));
  }
  return per_item / (4.0 * static_cast<double>(std::max(height, width)));
}

at::Tensor local_loss(const at::Tensor& pred_points, const at::Tensor& gt_points,
                      const at::Tensor& gt_rays, const at::Tensor& mask,
                      const at::Tensor& global_scale, int64_t level,
                      const LocalLossOptions& options, at::Generator generator,
                      const at::Tensor& sparse) {
  check_map(pred_points, 4, "predicted points");
  if (level <= 0) throw std::invalid_argument("local loss: the level must be positive");
  const int64_t batch = pred_points.size(0), height = pred_points.size(1),
                width = pred_points.size(2);
  const auto float_options = pred_points.options();
  const auto long_options = at::TensorOptions().dtype(at::kLong).device(pred_points.device());
  at::Tensor loss = at::zeros({batch}, float_options);

  const double radius = 0.5 / static_cast<double>(level) * std::hypot(height, width);
  const int64_t radius_2d = static_cast<int64_t>(std::ceil(radius));

  // Anchors: uniform among each item's labelled pixels (drawn on the CPU for reproducibility).
  const at::Tensor mask_cpu = mask.to(at::kCPU);
  std::vector<at::Tensor> anchor_items, anchor_pixels;
  for (int64_t b = 0; b < batch; ++b) {
    const at::Tensor labelled = mask_cpu[b].reshape({-1}).nonzero().squeeze(1);
    if (labelled.numel() == 0) continue;
    const at::Tensor pick =
        at::randint(labelled.numel(), {options.patches_per_item}, generator, at::kLong);
    anchor_pixels.push_back(labelled.index_select(0, pick));
    anchor_items.push_back(at::full({options.patches_per_item}, b, at::kLong));
  }
  if (anchor_items.empty()) return loss;
  const at::Tensor item = at::cat(anchor_items).to(pred_points.device());
  const at::Tensor pixel = at::cat(anchor_pixels).to(pred_points.device());
  const at::Tensor anchor_i = at::floor_divide(pixel, width), anchor_j = pixel.remainder(width);
  const int64_t num_patches = item.numel();

  const at::Tensor offsets = at::arange(-radius_2d, radius_2d + 1, long_options);
  const at::Tensor patch_i = anchor_i.view({-1, 1, 1}) + offsets.view({1, -1, 1});
  const at::Tensor patch_j = anchor_j.view({-1, 1, 1}) + offsets.view({1, 1, -1});
  const at::Tensor inside =
      (patch_i >= 0) & (patch_i < height) & (patch_j >= 0) & (patch_j < width);
  const at::Tensor flat = (item.view({-1, 1, 1}) * height + patch_i.clamp(0, height - 1)) * width +
                          patch_j.clamp(0, width - 1);
  const auto gather = [&](const at::Tensor& map) {
    const at::Tensor rows =
        map.reshape({batch * height * width, -1}).index_select(0, flat.reshape({-1}));
    return rows.view({num_patches, -1, map.dim() == 4 ? 3 : 1});
  };
  const at::Tensor gt_flat = gt_points.reshape({-1, 3});
  const at::Tensor anchor_flat = (item * height + anchor_i) * width + anchor_j;
  const at::Tensor gt_anchor = gt_flat.index_select(0, anchor_flat);  // (P,3)

  // The angle between neighbouring pixels' rays at the anchor (the right neighbour, or the
  // left one in the last column): the camera's local angular resolution.
  const at::Tensor neighbour_j = at::where(anchor_j + 1 < width, anchor_j + 1, anchor_j - 1);
  const at::Tensor rays_flat = gt_rays.reshape({-1, 3});
  const at::Tensor pixel_angle =
      angle_between(rays_flat.index_select(0, anchor_flat),
                    rays_flat.index_select(0, (item * height + anchor_i) * width + neighbour_j));
  const at::Tensor radius_3d = radius * pixel_angle * gt_anchor.norm(2, {-1});  // (P)

  const at::Tensor gt_patch = gather(gt_points);      // (P,n,3)
  const at::Tensor pred_patch = gather(pred_points);  // (P,n,3)
  const at::Tensor window = inside.reshape({num_patches, -1});
  at::Tensor patch_mask = window & gather(mask).squeeze(-1);
  // A sparse item's patch counts as a dense one would: divided by its window's label density
  // (at least the anchor's pixel is labelled).
  at::Tensor density_factor = at::ones({num_patches}, float_options);
  if (sparse.defined()) {
    const at::Tensor density = patch_mask.sum(1).to(pred_points.scalar_type()) /
                               window.sum(1).to(pred_points.scalar_type());
    density_factor = at::where(sparse.to(pred_points.device()).index_select(0, item),
                               1.0 / density.clamp_min(1e-12), density_factor);
  }
  patch_mask =
      patch_mask & ((gt_patch - gt_anchor.unsqueeze(1)).norm(2, {-1}) <= radius_3d.unsqueeze(1));
  const at::Tensor enough = patch_mask.sum(1) >= options.min_points;

  at::Tensor scale, shift;
  {
    at::NoGradGuard no_grad;
    at::Tensor fit_pred = pred_patch.detach(), fit_gt = gt_patch,
               fit_mask = patch_mask & enough.unsqueeze(1);
    if (options.fit_points > 0 && fit_mask.size(1) > options.fit_points) {
      // A uniform subset of each patch's usable points: the fit_points smallest of random keys,
      // the unusable points keyed above every usable one.
      const at::Tensor keys =
          at::rand({num_patches, fit_mask.size(1)}, generator, at::kFloat).to(fit_mask.device());
      const at::Tensor chosen = std::get<1>(keys.masked_fill(fit_mask.logical_not(), 2.0)
                                                .topk(options.fit_points, 1, /*largest=*/false,
                                                      /*sorted=*/false));
      const at::Tensor chosen3 = chosen.unsqueeze(-1).expand({-1, -1, 3});
      fit_pred = fit_pred.gather(1, chosen3);
      fit_gt = fit_gt.gather(1, chosen3);
      fit_mask = fit_mask.gather(1, chosen);
    }
    const at::Tensor weight = at::ones({num_patches, fit_gt.size(1)}, float_options) /
                              radius_3d.clamp_min(1e-12).unsqueeze(1);
    const geometry::AffineFit fit =
        geometry::fit_points_affine_l1(fit_pred, fit_gt, weight, fit_mask);
    const at::Tensor global = global_scale.index_select(0, item);
    const at::Tensor ratio = fit.scale / global;
    const at::Tensor valid = enough & positive_finite(fit.scale) & positive_finite(global) &
                             (ratio > 0.1) & (ratio < 10.0) & at::isfinite(fit.shift).all(-1);
    scale = at::where(valid, fit.scale, at::zeros_like(fit.scale));
    shift = at::where(valid.unsqueeze(-1), fit.shift, at::zeros_like(fit.shift));
    patch_mask = patch_mask & valid.unsqueeze(1);
  }

  // Each item's harmonic mean distance bounds the weights of near points.
  const at::Tensor maskf = mask.to(pred_points.scalar_type());
  const at::Tensor inverse_sum = (maskf / gt_points.norm(2, {-1}).clamp_min(1e-12)).sum({1, 2});
  const at::Tensor harmonic = maskf.sum({1, 2}) / inverse_sum.clamp_min(1e-12);
  const at::Tensor weight =
      patch_mask.to(pred_points.scalar_type()) /
      at::maximum(gt_patch.norm(2, {-1}), 0.1 * harmonic.index_select(0, item).unsqueeze(1));
  const at::Tensor aligned = scale.view({-1, 1, 1}) * pred_patch + shift.unsqueeze(1);
  const at::Tensor per_patch =
      ((aligned - gt_patch).abs() * weight.unsqueeze(-1)).mean({1, 2}) * density_factor;
  return loss.index_add(0, item, per_patch) / static_cast<double>(options.patches_per_item);
}

at::Tensor mask_loss(const at::Tensor& logits, const at::Tensor& positive,
                     const at::Tensor& negative) {
  check_map(logits, 3, "mask logits");
  const at::Tensor target = positive.to(logits.scalar_type());
  const at::Tensor bce =
      at::binary_cross_entropy_with_logits(logits, target, {}, {}, at::Reduction::None);
  return (bce * (positive | negative).to(logits.scalar_type())).mean({1, 2});
}

Losses compute_losses(const model::OmniPointOutput& output, const LossTargets& targets,
                      const LossConfig& config, at::Generator generator) {
  check_map(output.distance, 3, "predicted distance");
  check_map(targets.rays, 4, "target rays");
  check_map(targets.distance, 3, "target distance");
  check_map(targets.mask, 3, "target mask");
  if (targets.distance.sizes() != output.distance.sizes())
    throw std::invalid_argument("training loss: the targets must have the prediction's size " +
                                std::to_string(output.distance.size(1)) + "x" +
                                std::to_string(output.distance.size(2)));
  const auto options = output.distance.options();
  const at::Tensor gt_rays = targets.rays.to(options);
  const at::Tensor mask = targets.mask.to(output.distance.device());
  const at::Tensor gt_distance =
      at::where(mask, targets.distance.to(options), at::zeros_like(output.distance));
  const at::Tensor gt_points = gt_distance.unsqueeze(-1) * gt_rays;
  const bool xyz = !output.ray_raw.defined();
  const PointLoss kind = xyz ? PointLoss::kNaive : config.point_loss;
  const LossWeights& w = config.weights;
  const at::Tensor sparse =
      targets.sparse.defined() ? targets.sparse.to(mask.device(), at::kBool) : at::Tensor();

  // The scale-invariant point map the geometric terms see (losses.h).
  const at::Tensor own_points = output.distance.unsqueeze(-1) * output.rays;
  const at::Tensor points =
      kind == PointLoss::kDecoupled ? output.distance.unsqueeze(-1) * gt_rays : own_points;

  Losses losses;
  auto clock = std::chrono::steady_clock::now();
  const auto lap = [&] {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - clock).count();
    clock = now;
    return seconds;
  };
  if (config.align_points > 0 && mask[0].numel() > config.align_points) {
    // s* from a uniform subset of each item's labelled pixels, laid out as (B, 1, N) maps.
    at::NoGradGuard no_grad;
    const int64_t batch = mask.size(0);
    const at::Tensor flat_mask = mask.reshape({batch, -1});
    const at::Tensor keys = at::rand(flat_mask.sizes(), generator, at::kFloat).to(mask.device());
    const at::Tensor chosen = std::get<1>(keys.masked_fill(flat_mask.logical_not(), 2.0)
                                              .topk(config.align_points, 1, /*largest=*/false,
                                                    /*sorted=*/false));
    const auto pick = [&](const at::Tensor& map) {
      const at::Tensor rows = map.reshape({batch, flat_mask.size(1), -1});
      return rows.gather(1, chosen.unsqueeze(-1).expand({-1, -1, rows.size(2)}))
          .view({batch, 1, config.align_points, -1});
    };
    const at::Tensor subset_mask = flat_mask.gather(1, chosen).view({batch, 1, -1});
    losses.scale =
        kind == PointLoss::kDisjoint
            ? alignment_scale(pick(output.distance).squeeze(-1), pick(gt_distance).squeeze(-1),
                              subset_mask, config.align_trunc)
            : alignment_scale(pick(points), pick(gt_points), subset_mask, config.align_trunc);
  } else {
    losses.scale = kind == PointLoss::kDisjoint
                       ? alignment_scale(output.distance, gt_distance, mask, config.align_trunc)
                       : alignment_scale(points, gt_points, mask, config.align_trunc);
  }
  losses.seconds["scale"] = lap();
  at::Tensor total = at::zeros({output.distance.size(0)}, options);
  const auto add = [&](const char* name, double weight, const at::Tensor& term) {
    losses.terms[name] = term;
    total = total + weight * term;
    losses.seconds[name] = lap();
  };
  if (w.point != 0.0) {
    const at::Tensor weight = inverse_distance_weight(gt_points, mask);
    const at::Tensor point =
        kind == PointLoss::kDisjoint
            ? aligned_l1_loss(output.distance, gt_distance, weight, losses.scale)
            : aligned_l1_loss(points, gt_points, weight, losses.scale);
    add("point", w.point,
        sparse.defined() ? point * sparse_label_factor(mask, sparse).to(point.scalar_type())
                         : point);
  }
  if (w.ray != 0.0 && !xyz)
    add("ray", w.ray, ray_loss(output.rays, gt_rays, gt_rays.abs().sum(-1) > 0));
  if (w.metric != 0.0 && targets.metric.defined())
    add("metric", w.metric,
        metric_scale_loss(output.log_metric_scale, losses.scale,
                          targets.metric.to(output.distance.device())));
  if (w.normal != 0.0) add("normal", w.normal, normal_loss(points, gt_points, mask, sparse));
  if (w.gauge != 0.0) add("gauge", w.gauge, gauge_loss(output.distance, mask));
  if (w.local != 0.0) {
    at::Tensor local = at::zeros_like(total);
    for (const int64_t level : config.local.levels)
      local = local + local_loss(points, gt_points, gt_rays, mask, losses.scale, level,
                                 config.local, generator, sparse);
    add("local", w.local, local);
  }
  if (w.mask != 0.0) {
    const at::Tensor negative = targets.mask_negative.defined()
                                    ? targets.mask_negative.to(mask.device())
                                    : at::zeros_like(mask);
    add("mask", w.mask, mask_loss(output.mask_logits, mask, negative));
  }
  losses.total = total.mean();
  return losses;
}

}  // namespace omnipoint::train
