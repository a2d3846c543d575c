#include "omnipoint/eval/metrics.h"

#include <ATen/ATen.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "omnipoint/geometry/alignment.h"

namespace omnipoint::eval {

const std::array<const char*, 7> kMetricEntries = {
    "depth_metric",           "depth_scale_invariant",
    "depth_affine_invariant", "disparity_affine_invariant",
    "points_metric",          "points_scale_invariant",
    "points_affine_invariant"};

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRelEps = 1e-6;  // MoGe's denominators g + 1e-6, ‖g‖ + 1e-6

// MoGe's formulas, kept as they are for parity. A non-positive aligned depth passes its δ1
// test (both ratios are negative); `notes` records how many there were.
Score depth_score(const at::Tensor& p, const at::Tensor& g, const std::string& entry,
                  std::vector<std::string>& notes) {
  const int64_t non_positive = (p <= 0).sum().item<int64_t>();
  if (non_positive > 0) {
    notes.push_back(entry + ": " + std::to_string(non_positive) +
                    " aligned depths are <= 0 (MoGe's delta1 counts them as within 1.25)");
  }
  const double rel = ((p - g).abs() / (g + kRelEps)).mean().item<double>();
  const double delta1 =
      (at::maximum(g / p, p / g) < 1.25).to(p.scalar_type()).mean().item<double>();
  return {rel, delta1};
}

Score points_score(const at::Tensor& p, const at::Tensor& g) {
  const at::Tensor error = (p - g).norm(2, -1);
  const at::Tensor g_norm = g.norm(2, -1), p_norm = p.norm(2, -1);
  const double rel = (error / (g_norm + kRelEps)).mean().item<double>();
  const double delta1 =
      (error < 0.25 * at::minimum(g_norm, p_norm)).to(p.scalar_type()).mean().item<double>();
  return {rel, delta1};
}

std::vector<double> to_vector(const at::Tensor& t) {
  const at::Tensor c = t.to(at::kCPU, at::kDouble).contiguous().flatten();
  return std::vector<double>(c.data_ptr<double>(), c.data_ptr<double>() + c.numel());
}

bool all_finite(const at::Tensor& t) {
  return at::isfinite(t).all().item<bool>();
}

// Whether all samples (rows along dim 0) are equal: an affine fit's scale is then undetermined.
bool constant_rows(const at::Tensor& t) {
  return t.numel() == 0 || at::equal(t, t[0].expand_as(t));
}

// Records an entry; a non-finite score becomes NaN with a warning naming the reason.
void record(Metrics& out, const std::string& entry, Score score, Alignment alignment,
            const std::string& reason) {
  if (!std::isfinite(score.rel) || !std::isfinite(score.delta1) ||
      (!std::isnan(alignment.scale) && !std::isfinite(alignment.scale))) {
    score = {kNaN, kNaN};
    out.warnings.push_back(entry + ": undefined (" + reason + ")");
  }
  out.entries[entry] = score;
  out.alignment[entry] = std::move(alignment);
}

void record_undefined(Metrics& out, const std::string& entry, const std::string& reason) {
  out.entries[entry] = {kNaN, kNaN};
  out.alignment[entry] = {kNaN, {}, kNaN};
  out.warnings.push_back(entry + ": undefined (" + reason + ")");
}

void check_map(const at::Tensor& t, const at::Tensor& mask, bool points, const char* name) {
  if (!t.defined()) return;
  auto expected = mask.sizes().vec();
  if (points) expected.push_back(3);
  if (t.sizes() != at::IntArrayRef(expected) || !at::isFloatingType(t.scalar_type())) {
    throw std::invalid_argument(std::string("metrics: ") + name +
                                " must be a floating tensor of shape " +
                                (points ? "(H, W, 3)" : "(H, W)") + " matching the mask");
  }
}

void depth_entries(Metrics& out, const Prediction& pred, const GroundTruth& gt,
                   const at::Tensor& lr_flat) {
  const bool metric = gt.is_metric && pred.is_metric;
  std::vector<std::string> names;
  if (metric) names.emplace_back("depth_metric");
  for (const char* name :
       {"depth_scale_invariant", "depth_affine_invariant", "disparity_affine_invariant"})
    names.emplace_back(name);
  auto undefined = [&](const std::string& reason) {
    for (const auto& name : names) record_undefined(out, name, reason);
  };
  if (out.num_valid_pixels == 0) return undefined("no valid pixel in the mask");
  const at::Tensor g = gt.depth.masked_select(gt.mask);
  const at::Tensor p = pred.depth.masked_select(gt.mask).to(g.scalar_type());
  if (!all_finite(g) || !(g > 0).all().item<bool>())
    return undefined("ground-truth depth is not finite and positive inside the mask");
  if (!all_finite(p)) return undefined("predicted depth has NaN/inf at valid pixels");

  const at::Tensor g_sub = gt.depth.flatten().index_select(0, lr_flat);
  const at::Tensor p_sub = pred.depth.flatten().index_select(0, lr_flat).to(g.scalar_type());
  const at::Tensor w_sub = 1 / g_sub;

  if (metric)
    record(out, "depth_metric", depth_score(p, g, "depth_metric", out.warnings), {kNaN, {}, kNaN},
           "non-finite score");

  const at::Tensor scale = geometry::fit_scale_l1(p_sub, g_sub, w_sub).scale;
  record(out, "depth_scale_invariant",
         depth_score(p * scale, g, "depth_scale_invariant", out.warnings),
         {scale.item<double>(), {}, kNaN}, "the prediction is zero on the alignment samples");

  if (constant_rows(p_sub)) {
    record_undefined(out, "depth_affine_invariant",
                     "the prediction is constant on the alignment samples");
  } else {
    const geometry::AffineFit affine = geometry::fit_affine_l1(p_sub, g_sub, w_sub);
    record(out, "depth_affine_invariant",
           depth_score(p * affine.scale + affine.shift, g, "depth_affine_invariant", out.warnings),
           {affine.scale.item<double>(), to_vector(affine.shift), kNaN}, "degenerate affine fit");
  }

  // Least squares on disparity over all valid pixels, in double; then clamped back to depth.
  const at::Tensor d = (1 / p).to(at::kDouble), target = (1 / g).to(at::kDouble);
  const double n = static_cast<double>(d.numel());
  const double sd = d.sum().item<double>(), st = target.sum().item<double>();
  const double sdd = (d * d).sum().item<double>(), sdt = (d * target).sum().item<double>();
  const double det = n * sdd - sd * sd;
  if (!(det > 1e-12 * n * sdd) || !std::isfinite(det)) {
    record_undefined(out, "disparity_affine_invariant",
                     "the predicted disparity is constant or not finite (zero depth)");
    return;
  }
  const double s = (n * sdt - sd * st) / det, t = (st - s * sd) / n;
  const double min_disparity = 1.0 / g.max().item<double>();
  const at::Tensor disparity = (s * (1 / p) + t).clamp_min(min_disparity);
  record(out, "disparity_affine_invariant",
         depth_score(1 / disparity, g, "disparity_affine_invariant", out.warnings),
         {s, {t}, min_disparity}, "degenerate disparity fit");
}

void point_entries(Metrics& out, const Prediction& pred, const GroundTruth& gt,
                   const at::Tensor& lr_flat) {
  const bool metric = gt.is_metric && pred.is_metric;
  std::vector<std::string> names;
  if (metric) names.emplace_back("points_metric");
  for (const char* name : {"points_scale_invariant", "points_affine_invariant"})
    names.emplace_back(name);
  auto undefined = [&](const std::string& reason) {
    for (const auto& name : names) record_undefined(out, name, reason);
  };
  if (out.num_valid_pixels == 0) return undefined("no valid pixel in the mask");
  const at::Tensor mask3 = gt.mask.unsqueeze(-1).expand_as(gt.points);
  const at::Tensor g = gt.points.masked_select(mask3).view({-1, 3});
  const at::Tensor p = pred.points.masked_select(mask3).view({-1, 3}).to(g.scalar_type());
  if (!all_finite(g) || !(g.norm(2, -1) > 0).all().item<bool>())
    return undefined("ground-truth points are not finite and non-zero inside the mask");
  if (!all_finite(p)) return undefined("predicted points have NaN/inf at valid pixels");

  const at::Tensor g_sub = gt.points.reshape({-1, 3}).index_select(0, lr_flat);
  const at::Tensor p_sub =
      pred.points.reshape({-1, 3}).index_select(0, lr_flat).to(g.scalar_type());
  const at::Tensor w_sub = 1 / g_sub.norm(2, -1);

  if (metric) {
    const at::Tensor shift = geometry::fit_points_shift_l1(p_sub, g_sub, w_sub);
    record(out, "points_metric", points_score(p + shift, g), {kNaN, to_vector(shift), kNaN},
           "degenerate shift fit");
  }
  const at::Tensor scale = geometry::fit_points_scale_l1(p_sub, g_sub, w_sub).scale;
  record(out, "points_scale_invariant", points_score(p * scale, g),
         {scale.item<double>(), {}, kNaN},
         "the predicted points are zero on the alignment samples");
  if (constant_rows(p_sub)) {
    record_undefined(out, "points_affine_invariant",
                     "the predicted points are all equal on the alignment samples");
  } else {
    const geometry::AffineFit affine = geometry::fit_points_affine_l1_anchored(p_sub, g_sub, w_sub);
    record(out, "points_affine_invariant", points_score(p * affine.scale + affine.shift, g),
           {affine.scale.item<double>(), to_vector(affine.shift), kNaN}, "degenerate affine fit");
  }
}

}  // namespace

Subsample mask_aware_subsample(const at::Tensor& mask, int64_t size) {
  if (!mask.defined() || mask.dim() != 2 || mask.scalar_type() != at::kBool || size < 1) {
    throw std::invalid_argument("mask_aware_subsample: mask must be an (H, W) bool tensor");
  }
  const int64_t height = mask.size(0), width = mask.size(1);
  const double fh = std::max(1.0, static_cast<double>(height) / size);
  const double fw = std::max(1.0, static_cast<double>(width) / size);
  const int64_t kh = static_cast<int64_t>(std::ceil(fh)), kw = static_cast<int64_t>(std::ceil(fw));
  const auto f32 = mask.options().dtype(at::kFloat);
  const auto i64 = mask.options().dtype(at::kLong);

  // Cell centres and window corners, in float32 as MoGe computes them.
  const at::Tensor unit = at::linspace(0.5 / size, 1.0 - 0.5 / size, size, f32);
  const at::Tensor cx = unit * static_cast<float>(width), cy = unit * static_cast<float>(height);
  const at::Tensor left = at::round(cx - static_cast<float>(fw / 2)).to(at::kLong);
  const at::Tensor top = at::round(cy - static_cast<float>(fh / 2)).to(at::kLong);

  // Candidates (size, size, kh·kw) in row-major window order.
  const at::Tensor dy = at::arange(kh, i64).repeat_interleave(kw),
                   dx = at::arange(kw, i64).repeat({kh});
  const at::Tensor rows =
      (top.view({-1, 1, 1}) + dy.view({1, 1, -1})).expand({size, size, kh * kw});
  const at::Tensor cols =
      (left.view({1, -1, 1}) + dx.view({1, 1, -1})).expand({size, size, kh * kw});
  const at::Tensor inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width);
  const at::Tensor r = rows.clamp(0, height - 1), c = cols.clamp(0, width - 1);
  const at::Tensor valid = inside & mask.flatten().index({(r * width + c)});
  const at::Tensor ddx = (c.to(at::kFloat) + 0.5f) - cx.view({1, -1, 1});
  const at::Tensor ddy = (r.to(at::kFloat) + 0.5f) - cy.view({-1, 1, 1});
  const at::Tensor distance = at::where(valid, ddx * ddx + ddy * ddy,
                                        at::full({}, std::numeric_limits<float>::infinity(), f32));
  const at::Tensor best = distance.argmin(-1, /*keepdim=*/true);
  const at::Tensor cell_mask = valid.any(-1);
  const at::Tensor zero = at::zeros({}, i64);
  const at::Tensor best_row = at::where(cell_mask, r.gather(-1, best).squeeze(-1), zero);
  const at::Tensor best_col = at::where(cell_mask, c.gather(-1, best).squeeze(-1), zero);
  return {at::stack({best_row, best_col}), cell_mask};
}

Metrics compute_metrics(const Prediction& prediction, const GroundTruth& ground_truth) {
  const at::Tensor& mask = ground_truth.mask;
  if (!mask.defined() || mask.dim() != 2 || mask.scalar_type() != at::kBool) {
    throw std::invalid_argument("metrics: the ground-truth mask must be an (H, W) bool tensor");
  }
  check_map(ground_truth.depth, mask, false, "ground-truth depth");
  check_map(ground_truth.points, mask, true, "ground-truth points");
  check_map(prediction.depth, mask, false, "predicted depth");
  check_map(prediction.points, mask, true, "predicted points");
  if (prediction.depth.defined() && !ground_truth.depth.defined()) {
    throw std::invalid_argument("metrics: a depth prediction needs the ground-truth depth");
  }

  Metrics out;
  out.num_valid_pixels = mask.sum().item<int64_t>();
  const Subsample sub = mask_aware_subsample(mask);
  const at::Tensor lr = sub.index.flatten(1).index({at::indexing::Slice(), sub.mask.flatten()});
  const at::Tensor lr_flat = lr[0] * mask.size(1) + lr[1];
  out.num_lowres_samples = lr_flat.numel();

  if (prediction.depth.defined()) depth_entries(out, prediction, ground_truth, lr_flat);
  if (prediction.points.defined() && ground_truth.points.defined())
    point_entries(out, prediction, ground_truth, lr_flat);
  return out;
}

std::map<std::string, AveragedScore> average_metrics(const std::vector<Metrics>& instances) {
  std::map<std::string, AveragedScore> out;
  for (const Metrics& metrics : instances) {
    for (const auto& [name, score] : metrics.entries) {
      AveragedScore& sum = out.try_emplace(name, AveragedScore{0.0, 0.0, 0, 0}).first->second;
      if (std::isnan(score.rel) || std::isnan(score.delta1)) {
        ++sum.excluded;
      } else {
        sum.rel += score.rel;
        sum.delta1 += score.delta1;
        ++sum.count;
      }
    }
  }
  for (auto& [name, sum] : out) {
    sum.rel = sum.count > 0 ? sum.rel / sum.count : kNaN;
    sum.delta1 = sum.count > 0 ? sum.delta1 / sum.count : kNaN;
  }
  return out;
}

}  // namespace omnipoint::eval
