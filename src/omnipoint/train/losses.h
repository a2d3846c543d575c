#pragma once
// OmniPoint's training objective (paper, "Decoupled objective" and "Loss Functions"):
//   L = L_point + λ_ray L_ray + λ_metric L_metric + λ_normal L_normal + λ_local L_local
//       + λ_mask L_mask
// with MoGe's conventions where the paper follows MoGe (train/losses.py of MoGe-2):
// - s* is the robust exact L1 scale (ROE, truncated at relative error 1) that aligns the
//   predicted scale-invariant point map to the ground truth; it is a constant for the
//   gradient (computed without autograd), and items without a positive finite s* get no
//   point, local or metric loss.
// - Per-pixel terms are weighted by 1 / ‖P_gt‖ (MoGe: 1 / z; distance is the camera-agnostic
//   counterpart), capped at 10× the item's mean weight, and averaged over all H·W·3 entries of
//   the item (unlabelled pixels contribute zero), so each image counts by its labelled area.
// - Every term is per batch item (B); the total is the mean over the batch.
//
// Shapes: point maps and rays (B,H,W,3), distances and masks (B,H,W), scales (B). Any
// floating dtype and device (taken from the inputs).
//
// Sparse labels (LossTargets::sparse: LiDAR or SfM samples, ~0.1–3 % of the pixels): an
// unlabelled pixel of such an item is unknown, not empty, so its labelled pixels stand for the
// whole image, and the terms that need neighbourhoods use the labels that exist or step aside:
//   point     the mean over the labelled pixels (the dense rule's H·W mean times H·W / labelled)
//   ray       unchanged: the rays come from the camera, dense on every item
//   metric    unchanged: s* fitted on the labelled pixels (no s*, no term)
//   gauge     unchanged: already a mean over the labelled pixels
//   normal    the mean over the 2×2 cells holding a labelled triangle (three labelled corners)
//             instead of over all cells; 0 when there is none
//   local     each patch's mean times (in-image window pixels / labelled ones): the patch counts
//             as a dense one would; patches with fewer than min_points labelled points in their
//             ball are skipped as on dense items, and an item without any gives 0
//   mask      labelled pixels positive, no negatives (the sample set no sky: the batch leaves
//             mask_negative empty); the H·W mean as on dense items
// With every pixel labelled each rule gives the dense value, and no rule divides by a count
// that can be 0 (an item without labels gives 0 in every term but ray).
//
// Point-loss variants (the paper's ablation, Tab. "Point Loss Mechanisms"), and the point map
// that L_point, L_local and L_normal see:
//   kDecoupled  (the paper's)   P̃ = d̂ · r (GT ray);  L_point = Σ‖s*·d̂·r − d·r‖₁ · w
//   kNaive                      P̃ = d̂ · r̂;          L_point = Σ‖s*·d̂·r̂ − d·r‖₁ · w
//   kDisjoint   (D + Ray)       no point loss:       L_point = Σ|s*·d̂ − d| · w (distances only)
//                               L_local and L_normal on d̂ · r̂
// With an XYZ output head (model OutputKind::kXyz) the network's own point map d̂ · r̂ is used
// as in kNaive, and L_ray is not applied (the rays are derived from the points).
#include <ATen/core/Generator.h>
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "omnipoint/model/omnipoint_model.h"

namespace omnipoint::train {

enum class PointLoss { kDecoupled, kNaive, kDisjoint };
// "decoupled" | "naive" | "disjoint" (the config's names); anything else -> std::invalid_argument.
PointLoss parse_point_loss(const std::string& name);
const std::vector<std::pair<std::string, PointLoss>>& point_loss_names();

struct LossWeights {
  double point = 1.0;
  double ray = 1.0;
  double metric = 1.0;
  double normal = 1.0;
  double local = 1.0;
  double mask = 1.0;
  // Not in the paper (0 = its objective): fixes the free global scale of the relative
  // distances, which every other geometric term ignores. Without it that scale can drift
  // quickly when training from scratch at high learning rates, and L_metric's target s*
  // drifts with it (observed: L_metric rising to ~8 within 100 steps at lr 5e-4).
  double gauge = 0.0;
};

// MoGe's multi-scale local loss: at each level, patches of radius 0.5/level of the image
// diagonal around random labelled anchors.
struct LocalLossOptions {
  std::vector<int64_t> levels{4, 16, 64};
  int64_t patches_per_item = 16;
  int64_t min_points = 32;  // patches with fewer labelled points inside their 3-D ball are skipped
  // 0 (MoGe's): each patch's scale and shift are the exact L1 fit over all its points. N > 0:
  // the exact fit over a uniform random subset of at most N of them (the loss still sums over
  // all): the fit's sorts dominated a CPU training step, and the fit is a constant for the
  // gradient, so an estimate from N points only adds noise to the alignment.
  int64_t fit_points = 0;
};

struct LossConfig {
  LossWeights weights;
  PointLoss point_loss = PointLoss::kDecoupled;
  double align_trunc = 1.0;  // truncation of the ROE scale fit (relative error)
  // 0 (MoGe's): s* is fitted on every labelled pixel. N > 0: on a uniform random subset of at
  // most N of each item's labelled pixels (like LocalLossOptions::fit_points; s* is a constant
  // for the gradient, and MoGe's evaluation fits on a 64×64 subsample too).
  int64_t align_points = 0;
  LocalLossOptions local;
};

struct LossTargets {
  at::Tensor rays;           // (B,H,W,3) GT unit rays, zero where the camera is invalid
  at::Tensor distance;       // (B,H,W) GT distances along them, used where `mask`
  at::Tensor mask;           // (B,H,W) bool: labelled geometry
  at::Tensor mask_negative;  // (B,H,W) bool: known to hold no geometry (sky); for L_mask
  at::Tensor metric;         // (B) bool: the distances are metric (L_metric)
  at::Tensor sparse;         // (B) bool: sparse labels (the rules above); undefined: all dense
};

struct Losses {
  at::Tensor total;  // () mean over the batch of the weighted sum
  std::map<std::string, at::Tensor>
      terms;         // "point", "ray", ...: (B) unweighted, computed terms only
  at::Tensor scale;  // (B) s*, NaN where undetermined
  std::map<std::string, double> seconds;  // the forward time of each term ("scale": s*)
};

// The whole objective for one batch. Terms whose weight is 0 are not computed. `generator`
// (CPU) draws the local-loss anchors.
Losses compute_losses(const model::OmniPointOutput& output, const LossTargets& targets,
                      const LossConfig& config, at::Generator generator);

// ---- The terms, for tests and custom objectives. ----

// The per-pixel weight mask / ‖gt‖, capped at 10× its mean over the item's labelled pixels.
at::Tensor inverse_distance_weight(const at::Tensor& gt_points, const at::Tensor& mask);

// s* = argmin_s Σ min(trunc, w·‖s·pred − gt‖₁) over labelled pixels, w = 1/‖gt‖, without
// autograd; NaN where no positive finite scale exists.
at::Tensor alignment_scale(const at::Tensor& pred_points, const at::Tensor& gt_points,
                           const at::Tensor& mask, double trunc);

// mean over H·W·3 of weight · |scale·pred − gt| (points (B,H,W,3), or distances (B,H,W) with
// the mean over H·W); items whose scale is not positive and finite give 0.
at::Tensor aligned_l1_loss(const at::Tensor& pred, const at::Tensor& gt, const at::Tensor& weight,
                           const at::Tensor& scale);

// mean over H·W of valid · ‖r̂ − r‖₁.
at::Tensor ray_loss(const at::Tensor& pred_rays, const at::Tensor& gt_rays,
                    const at::Tensor& valid);

// (log ŝ − log s*)² on items that are metric and have a positive finite s*; 0 elsewhere.
at::Tensor metric_scale_loss(const at::Tensor& log_pred_scale, const at::Tensor& target_scale,
                             const at::Tensor& metric);

// The gauge term: (mean over the labelled pixels of log d̂)² per item, i.e. it keeps the
// geometric mean of the predicted relative distances at 1; 0 for items without labels.
at::Tensor gauge_loss(const at::Tensor& distance, const at::Tensor& mask);

// MoGe's normal loss: the angles between the predicted and GT normals of the four triangles of
// every 2×2 pixel cell with three labelled corners, clamped to [1°, 90°], smoothed (Huber,
// β = 3°), averaged over the cells and divided by 4·max(H, W). Scale-invariant. The constant
// the clamp leaves at angle 0 is subtracted (zero for a perfect prediction; MoGe's gradients).
// `sparse` (B) bool, may be undefined: those items average over their labelled cells.
at::Tensor normal_loss(const at::Tensor& pred_points, const at::Tensor& gt_points,
                       const at::Tensor& mask, const at::Tensor& sparse = {});

// MoGe's local loss at one level: `patches_per_item` anchors drawn uniformly among the labelled
// pixels, window radius ceil(0.5/level · diagonal) pixels, kept are the labelled pixels within
// the 3-D radius (0.5/level · diagonal) · (the ray angle between neighbouring pixels at the
// anchor) · ‖anchor‖ — MoGe's 0.5/level/focal · z for any camera model; each patch aligned by
// the exact L1 scale + shift fit (constant for the gradient; over at most options.fit_points of
// the patch's points when that is > 0, drawn with `generator`), rejected when that scale is not
// within (0.1, 10)× `global_scale`, weighted by 1 / max(‖gt‖, 0.1 · the item's harmonic mean).
// Returns the sum over the item's patches divided by patches_per_item. `sparse` (B) bool, may
// be undefined: those items' patches are divided by their window's label density.
at::Tensor local_loss(const at::Tensor& pred_points, const at::Tensor& gt_points,
                      const at::Tensor& gt_rays, const at::Tensor& mask,
                      const at::Tensor& global_scale, int64_t level,
                      const LocalLossOptions& options, at::Generator generator,
                      const at::Tensor& sparse = {});

// Per item (B): H·W / its labelled pixels (at least 1) where `sparse`, 1 elsewhere; the
// factor that turns an H·W mean into a mean over the labelled pixels.
at::Tensor sparse_label_factor(const at::Tensor& mask, const at::Tensor& sparse);

// Binary cross-entropy of the mask logits against positive (1) and negative (0) pixels, mean
// over H·W; pixels that are neither contribute nothing.
at::Tensor mask_loss(const at::Tensor& logits, const at::Tensor& positive,
                     const at::Tensor& negative);

}  // namespace omnipoint::train
