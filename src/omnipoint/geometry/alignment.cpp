// Robust exact L1 alignment. Internally every problem is brought to the form
// "C axes of n samples that share one scale": X, Y, W of shape (B, C, n), masked samples
// zeroed (x = y = w = 0, which makes them inert in every formula below).
#include "omnipoint/geometry/alignment.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace omnipoint::geometry {
namespace {

constexpr double kRatioEps = 1e-7;  // MoGe's clamp of |x| in the ratio y/x
constexpr int kMaxPivotIterations = 64;
constexpr int64_t kMaxElementsPerChunk = int64_t{1} << 22;

void check_same_shape(const at::Tensor& a, const at::Tensor& b, const char* name_a,
                      const char* name_b) {
  if (!a.defined() || !b.defined() || a.sizes() != b.sizes()) {
    throw std::invalid_argument(std::string("alignment: ") + name_a + " and " + name_b +
                                " must be defined tensors of the same shape");
  }
}

void check_inputs(const at::Tensor& x, const at::Tensor& y, const at::Tensor& weight,
                  const at::Tensor& mask) {
  check_same_shape(x, y, "source", "target");
  if (!at::isFloatingType(x.scalar_type()) || x.scalar_type() != y.scalar_type()) {
    throw std::invalid_argument("alignment: source and target must share a floating dtype");
  }
  if (x.dim() < 1) throw std::invalid_argument("alignment: samples need at least one dimension");
  check_same_shape(x, weight, "samples", "weight");
  if (mask.defined()) {
    check_same_shape(x, mask, "samples", "mask");
    if (mask.scalar_type() != at::kBool)
      throw std::invalid_argument("alignment: mask must be bool");
  }
}

// Zeroes masked samples so that they carry no weight and no NaN/inf.
std::tuple<at::Tensor, at::Tensor, at::Tensor> sanitize(const at::Tensor& x, const at::Tensor& y,
                                                        const at::Tensor& weight,
                                                        const at::Tensor& mask) {
  const at::Tensor w = weight.to(x.scalar_type());
  if (!mask.defined()) return {x, y, w};
  const at::Tensor zero = at::zeros({}, x.options());
  return {at::where(mask, x, zero), at::where(mask, y, zero), at::where(mask, w, zero)};
}

// Gives sample-less rows one inert (zero-weight) sample, so that every solver below sees
// n >= 1 and reports "no usable sample" as NaN.
at::Tensor pad_empty(const at::Tensor& t) {
  return t.size(-1) == 0 ? at::constant_pad_nd(t, {0, 1}, 0.0) : t;
}

// Position, along the last dim of the sorted weights, of the first element whose
// cumulative weight reaches half of the total (MoGe's tie rule).
at::Tensor median_position(const at::Tensor& sorted_weight) {
  const int64_t n = sorted_weight.size(-1);
  const at::Tensor cumulative = sorted_weight.cumsum(-1);
  const at::Tensor total = cumulative.narrow(-1, n - 1, 1);
  return (2 * cumulative - total < 0).sum(-1, /*keepdim=*/true).clamp_max(n - 1);
}

at::Tensor nan_like(const at::Tensor& t) {
  return at::full_like(t, std::numeric_limits<double>::quiet_NaN());
}

// Weighted-median scale on (B, n) sanitized samples.
ScaleFit scale_fit_rows(const at::Tensor& x, const at::Tensor& y, const at::Tensor& w) {
  const at::Tensor sign = x.sign();
  const at::Tensor xs = x * sign;
  const at::Tensor ys = y * sign;
  at::Tensor ratio, order;
  std::tie(ratio, order) = (ys / xs.clamp_min(kRatioEps)).sort(-1);
  const at::Tensor sorted_wx = (w * xs).gather(-1, order);
  const at::Tensor pos = median_position(sorted_wx);
  at::Tensor scale = ratio.gather(-1, pos).squeeze(-1);
  at::Tensor index = order.gather(-1, pos).squeeze(-1);
  at::Tensor loss = (w * (scale.unsqueeze(-1) * x - y).abs()).sum(-1);
  const at::Tensor empty = sorted_wx.sum(-1) <= 0;
  scale = at::where(empty, nan_like(scale), scale);
  loss = at::where(empty, nan_like(loss), loss);
  index = at::where(empty, at::full_like(index, -1), index);
  return {scale, loss, index};
}

ScaleFit reshape_fit(const ScaleFit& fit, at::IntArrayRef batch_shape) {
  return {fit.scale.reshape(batch_shape), fit.loss.reshape(batch_shape),
          fit.index.reshape(batch_shape)};
}

// Truncated scale on (B, n) sanitized samples. Every term is
//   min(T, c|a − A|),  c = w|x|, A = y/x,
// zero at A, linear up to T on (B, C) = (A − T/c, A + T/c) and flat outside. Between two
// consecutive A's the objective is a sum of concave pieces, so its minimum is one of the A's.
// With the A, B and C sorted and prefix sums of (1, c, c·A) in each order, the objective at
// every A is assembled in O(n log n): f(a) = Σ_const + T·#active − Σ_{B<a≤A}(T − c(A − a))
// − Σ_{A<a<C}(T − c(a − A)).
ScaleFit truncated_scale_fit_rows(const at::Tensor& x_in, const at::Tensor& y_in,
                                  const at::Tensor& w_in, double trunc) {
  const at::Tensor x = x_in.to(at::kDouble), y = y_in.to(at::kDouble), w = w_in.to(at::kDouble);
  const double inf = std::numeric_limits<double>::infinity();
  const at::Tensor sign = x.sign();
  const at::Tensor xs = x * sign, ys = y * sign;
  const at::Tensor c = w * xs;
  const at::Tensor active = c > 0;
  const at::Tensor inf_t = at::full({}, inf, x.options());
  const at::Tensor c_safe = at::where(active, c, at::ones_like(c));
  const at::Tensor A =
      at::where(active, ys / xs.clamp_min(std::numeric_limits<double>::min()), inf_t);
  // Keep B < A < C strictly even where T/c vanishes against A in rounding.
  const at::Tensor B = at::minimum(A - trunc / c_safe, at::nextafter(A, -inf_t));
  const at::Tensor C = at::maximum(A + trunc / c_safe, at::nextafter(A, inf_t));
  const at::Tensor B_s = at::where(active, B, inf_t), C_s = at::where(active, C, inf_t);
  const at::Tensor constant_terms =
      at::where(active, at::zeros_like(c),
                at::minimum(w * y.abs(), at::full({}, trunc, x.options())))
          .sum(-1, true);

  const at::Tensor one = active.to(at::kDouble);
  const at::Tensor cA = at::where(active, c * A, at::zeros_like(c));
  // Prefix sums (with a leading 0) of (1, c, cA) in the order of `keys`.
  auto prefix = [&](const at::Tensor& keys) {
    at::Tensor sorted, order;
    std::tie(sorted, order) = keys.sort(-1);
    auto cum = [&](const at::Tensor& v) {
      return at::constant_pad_nd(v.gather(-1, order).cumsum(-1), {1, 0}, 0.0);
    };
    return std::make_tuple(sorted, cum(one), cum(at::where(active, c, at::zeros_like(c))), cum(cA));
  };
  at::Tensor sA, nA1, cA1, aA1, sB, nB1, cB1, aB1, sC, nC1, cC1, aC1;
  std::tie(sA, nA1, cA1, aA1) = prefix(A);
  std::tie(sB, nB1, cB1, aB1) = prefix(B_s);
  std::tie(sC, nC1, cC1, aC1) = prefix(C_s);
  const at::Tensor a = at::where(active, A, at::zeros_like(A));  // queries
  const at::Tensor iB = at::searchsorted(sB, a, false, false);   // #{B < a}
  const at::Tensor iA = at::searchsorted(sA, a, false, false);   // #{A < a}
  const at::Tensor iC = at::searchsorted(sC, a, false, true);    // #{C <= a}
  auto at_ = [](const at::Tensor& v, const at::Tensor& i) { return v.gather(-1, i); };
  const at::Tensor left_n = at_(nB1, iB) - at_(nA1, iA), left_c = at_(cB1, iB) - at_(cA1, iA),
                   left_a = at_(aB1, iB) - at_(aA1, iA);
  const at::Tensor right_n = at_(nA1, iA) - at_(nC1, iC), right_c = at_(cA1, iA) - at_(cC1, iC),
                   right_a = at_(aA1, iA) - at_(aC1, iC);
  at::Tensor objective = constant_terms + trunc * one.sum(-1, true) -
                         (trunc * left_n - (left_a - a * left_c)) -
                         (trunc * right_n - (a * right_c - right_a));
  objective = at::where(active, objective, inf_t);
  at::Tensor index = objective.argmin(-1, /*keepdim=*/true);

  const auto dtype = x_in.scalar_type();
  const at::Tensor xk = x_in.gather(-1, index), yk = y_in.gather(-1, index);
  const at::Tensor sk = xk.sign();
  at::Tensor scale = ((yk * sk) / (xk * sk).clamp_min(kRatioEps)).squeeze(-1);
  at::Tensor loss =
      (w_in * (scale.unsqueeze(-1) * x_in - y_in).abs()).clamp_max(trunc).sum(-1).to(dtype);
  index = index.squeeze(-1);
  const at::Tensor empty = ~active.any(-1);
  scale = at::where(empty, nan_like(scale), scale);
  loss = at::where(empty, nan_like(loss), loss);
  index = at::where(empty, at::full_like(index, -1), index);
  return {scale, loss, index};
}

// Weighted-median pivots of the residuals R = Y − s·X per axis (B, C, 1), and the
// derivative of F(s) = Σ_c min_t Σ_i w|R_i − t| there: Σ_i w_i·σ_i·(X_k − X_i), with
// σ_i = +1 after the pivot k in sorted order and −1 before it. Meant for slopes s that are
// not breakpoints of F (no tie among the residuals), where F is differentiable.
std::pair<at::Tensor, at::Tensor> median_pivots(const at::Tensor& X, const at::Tensor& Y,
                                                const at::Tensor& W, const at::Tensor& s) {
  const at::Tensor order = std::get<1>((Y - s.view({-1, 1, 1}) * X).sort(-1));
  const at::Tensor ws = W.gather(-1, order);
  const at::Tensor wxs = ws * X.gather(-1, order);
  const at::Tensor pos = median_position(ws);
  const at::Tensor pivot = order.gather(-1, pos);
  const at::Tensor cw = ws.cumsum(-1), cwx = wxs.cumsum(-1);
  const at::Tensor w_upto = cw.gather(-1, pos), wx_upto = cwx.gather(-1, pos);
  const at::Tensor w_before = w_upto - ws.gather(-1, pos),
                   wx_before = wx_upto - wxs.gather(-1, pos);
  const at::Tensor w_after = cw.narrow(-1, cw.size(-1) - 1, 1) - w_upto;
  const at::Tensor wx_after = cwx.narrow(-1, cwx.size(-1) - 1, 1) - wx_upto;
  const at::Tensor derivative =
      (X.gather(-1, pivot) * (w_after - w_before) - (wx_after - wx_before)).sum({-2, -1});
  return {pivot, derivative};
}

// The best scale through the given pivots: min_σ Σ_c Σ_i w|(Y − Y_k) − σ(X − X_k)|.
at::Tensor scale_through(const at::Tensor& X, const at::Tensor& Y, const at::Tensor& W,
                         const at::Tensor& pivot) {
  const at::Tensor x = (X - X.gather(-1, pivot)).flatten(1),
                   y = (Y - Y.gather(-1, pivot)).flatten(1);
  return scale_fit_rows(x, y, W.flatten(1)).scale;
}

// The optimal shifts for a given scale (per-axis weighted medians of the residuals).
at::Tensor median_shift(const at::Tensor& X, const at::Tensor& Y, const at::Tensor& W,
                        const at::Tensor& s) {
  const at::Tensor R = Y - s.view({-1, 1, 1}) * X;
  at::Tensor sorted, order;
  std::tie(sorted, order) = R.sort(-1);
  return sorted.gather(-1, median_position(W.gather(-1, order))).squeeze(-1);
}

at::Tensor affine_loss(const at::Tensor& X, const at::Tensor& Y, const at::Tensor& W,
                       const at::Tensor& scale, const at::Tensor& shift) {
  return (W * (scale.view({-1, 1, 1}) * X + shift.unsqueeze(-1) - Y).abs()).sum({-2, -1});
}

// Exact min_{s, t_c} Σ_{c,i} w_ci |s·X_ci + t_c − Y_ci| on (B, C, n) sanitized samples.
//
// F(s) = Σ_c min_t (...) is convex and piecewise linear in s; its breakpoints are the
// slopes at which two residuals of an axis tie. Let k_c be the median pivots at a slope p
// that is not a breakpoint. M(σ) = Σ_c Σ_i w|(Y − Y_k) − σ(X − X_k)| (the shifts forced
// through the pivots) is ≥ F(σ) everywhere and equals F around p. If F'(p) < 0, the
// minimiser σ of M (one weighted-median scale fit) lies beyond p with F(σ) ≤ M(σ) < F(p):
// a strict descent onto a breakpoint. Probing just right and left of the current
// breakpoint s (at s ± δ, δ a relative 1e-9, so that ties at s do not matter), the walk
// moves until F'(s − δ) ≤ 0 ≤ F'(s + δ). Breakpoints are finitely many, so it stops, with
// the convex F's minimum in [s − δ, s + δ]. The pivots at s ± δ lie on the pieces next to
// that minimum, so the better of the fits through them is the exact minimum whenever no
// other breakpoint lies within δ (otherwise it is within δ of it). Computed in float64.
AffineFit pivot_descent(const at::Tensor& X_in, const at::Tensor& Y_in, const at::Tensor& W_in) {
  const at::Tensor X = X_in.to(at::kDouble), Y = Y_in.to(at::kDouble), W = W_in.to(at::kDouble);
  const int64_t batch = X.size(0);
  constexpr double kProbe = 1e-9;
  at::Tensor s = scale_fit_rows(X.flatten(1), Y.flatten(1), W.flatten(1)).scale;
  s = at::where(at::isfinite(s), s, at::zeros_like(s));
  at::Tensor active = at::ones({batch}, X.options().dtype(at::kBool));
  auto probe = [&](const at::Tensor& s, double side) {
    return s + side * kProbe * s.abs().clamp_min(1e-6);
  };
  for (int iteration = 0; iteration < kMaxPivotIterations && active.any().item<bool>();
       ++iteration) {
    at::Tensor right_pivot, right_slope, left_pivot, left_slope;
    std::tie(right_pivot, right_slope) = median_pivots(X, Y, W, probe(s, 1));
    std::tie(left_pivot, left_slope) = median_pivots(X, Y, W, probe(s, -1));
    const at::Tensor go_right = right_slope < 0;
    const at::Tensor go_left = at::logical_and(at::logical_not(go_right), left_slope > 0);
    active = at::logical_and(active, at::logical_or(go_right, go_left));
    const at::Tensor pivot = at::where(go_right.view({-1, 1, 1}), right_pivot, left_pivot);
    const at::Tensor next = scale_through(X, Y, W, pivot);
    // In exact arithmetic a move always changes s; rounding can stall it at the optimum.
    active = at::logical_and(active, at::logical_and(at::isfinite(next), next != s));
    s = at::where(active, next, s);
  }
  // Settle: the better of the fits through the pivots on either side of the optimum.
  at::Tensor best_s = s, best_t = median_shift(X, Y, W, s);
  at::Tensor best_loss = affine_loss(X, Y, W, best_s, best_t);
  for (double side : {-1.0, 1.0}) {
    at::Tensor candidate = scale_through(X, Y, W, median_pivots(X, Y, W, probe(s, side)).first);
    candidate = at::where(at::isfinite(candidate), candidate, s);
    const at::Tensor shift = median_shift(X, Y, W, candidate);
    const at::Tensor loss = affine_loss(X, Y, W, candidate, shift);
    const at::Tensor better = loss < best_loss;
    best_s = at::where(better, candidate, best_s);
    best_t = at::where(better.unsqueeze(-1), shift, best_t);
    best_loss = at::where(better, loss, best_loss);
  }
  const at::Tensor empty = W.sum({-2, -1}) <= 0;
  best_s = at::where(empty, nan_like(best_s), best_s);
  best_t = at::where(empty.unsqueeze(-1), nan_like(best_t), best_t);
  const auto dtype = X_in.scalar_type();
  const at::Tensor scale = best_s.to(dtype), shift = best_t.to(dtype);
  return {scale, shift, affine_loss(X_in, Y_in, W_in, scale, shift)};
}

// MoGe's anchored search on (B, C, n): candidate samples j (all C axes pass through them)
// get a pooled scale fit through them, the lowest loss wins. Candidates are tried in order
// of their lower bound `lower` (B, n) and the search stops once no remaining bound is below
// the best loss found (up to a rounding slack); samples without weight are never tried.
AffineFit anchored_search(const at::Tensor& X, const at::Tensor& Y, const at::Tensor& W,
                          const at::Tensor& candidates, const at::Tensor& lower) {
  const int64_t batch = X.size(0), axes = X.size(1), n = X.size(2);
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<at::Tensor> scales, shifts;
  const int64_t max_chunk =
      std::max<int64_t>(1, kMaxElementsPerChunk / std::max<int64_t>(1, axes * n));
  for (int64_t b = 0; b < batch; ++b) {
    const at::Tensor xb = X[b], yb = Y[b], wb = W[b];  // (C, n)
    const at::Tensor usable = at::logical_and(candidates[b], (wb > 0).any(0));
    const at::Tensor bounds = at::where(usable, lower[b].to(at::kDouble),
                                        at::full({}, inf, lower.options().dtype(at::kDouble)));
    at::Tensor sorted_bounds, order;
    std::tie(sorted_bounds, order) = at::sort(bounds, /*stable=*/true, 0, false);
    const int64_t count = usable.sum().item<int64_t>();
    // Losses closer than the dtype's rounding are ties: no need to solve further anchors.
    const double slack =
        (X.scalar_type() == at::kDouble ? 1e-12 : 1e-6) * (wb * yb.abs()).sum().item<double>();
    const at::Tensor w_row = wb.flatten().unsqueeze(0);
    double best_loss = inf;
    at::Tensor best_scale = at::full({}, std::numeric_limits<double>::quiet_NaN(), X.options());
    at::Tensor best_anchor = at::zeros({}, X.options().dtype(at::kLong));
    int64_t chunk = std::min<int64_t>(16, max_chunk);
    for (int64_t start = 0; start < count; start += chunk, chunk = std::min(2 * chunk, max_chunk)) {
      if (sorted_bounds[start].item<double>() >= best_loss - slack) break;
      const at::Tensor ids = order.narrow(0, start, std::min(chunk, count - start));
      const at::Tensor x_rel =
          (xb.unsqueeze(0) - xb.index_select(1, ids).t().unsqueeze(-1)).flatten(1);
      const at::Tensor y_rel =
          (yb.unsqueeze(0) - yb.index_select(1, ids).t().unsqueeze(-1)).flatten(1);
      const ScaleFit fit = scale_fit_rows(x_rel, y_rel, w_row.expand_as(x_rel));
      // An anchor sharing x with every sample leaves the scale free: take 0.
      const at::Tensor free = at::isnan(fit.scale);
      const at::Tensor scale = at::where(free, at::zeros_like(fit.scale), fit.scale);
      const at::Tensor loss = at::where(free, (w_row * y_rel.abs()).sum(-1), fit.loss);
      const int64_t i = loss.argmin().item<int64_t>();
      if (loss[i].item<double>() < best_loss) {
        best_loss = loss[i].item<double>();
        best_scale = scale[i];
        best_anchor = ids[i];
      }
    }
    scales.push_back(best_scale);
    shifts.push_back(yb.index_select(1, best_anchor.view({1})).squeeze(1) -
                     best_scale * xb.index_select(1, best_anchor.view({1})).squeeze(1));
  }
  const at::Tensor scale = at::stack(scales), shift = at::stack(shifts);
  return {scale, shift, affine_loss(X, Y, W, scale, shift)};
}

// For every anchor j at once, the value and a subgradient of its anchored objective
//   Φ_j(s) = Σ_c Σ_i w_ci |R_ci − R_cj|,  R = Y − s·X,
// at each of the m slopes s (B, m): one sort per slope and axis plus prefix sums; tied
// residuals are taken in sorted order, which still gives a valid subgradient.
// Returns (value, slope), both (B, m, n).
std::pair<at::Tensor, at::Tensor> anchored_objectives(const at::Tensor& X, const at::Tensor& Y,
                                                      const at::Tensor& W, const at::Tensor& s) {
  const int64_t n = X.size(-1);
  const at::Tensor R =
      Y.unsqueeze(1) - s.view({s.size(0), s.size(1), 1, 1}) * X.unsqueeze(1);  // (B, m, C, n)
  at::Tensor sorted, order;
  std::tie(sorted, order) = R.sort(-1);
  const at::Tensor ws = W.unsqueeze(1).expand_as(R).gather(-1, order);
  const at::Tensor xs = X.unsqueeze(1).expand_as(R).gather(-1, order);
  // Inclusive prefix sums in sorted order; "below" excludes the element itself.
  const at::Tensor cw = ws.cumsum(-1), cwr = (ws * sorted).cumsum(-1), cwx = (ws * xs).cumsum(-1);
  auto total = [n](const at::Tensor& v) { return v.narrow(-1, n - 1, 1); };
  const at::Tensor w_lt = cw - ws, wr_lt = cwr - ws * sorted, wx_lt = cwx - ws * xs;
  const at::Tensor w_gt = total(cw) - cw, wr_gt = total(cwr) - cwr, wx_gt = total(cwx) - cwx;
  const at::Tensor value_sorted = sorted * w_lt - wr_lt + wr_gt - sorted * w_gt;
  const at::Tensor slope_sorted = xs * (w_gt - w_lt) - (wx_gt - wx_lt);
  // Back to anchor order, summed over the axes.
  const at::Tensor value = at::empty_like(R).scatter_(-1, order, value_sorted).sum(2);
  const at::Tensor slope = at::empty_like(R).scatter_(-1, order, slope_sorted).sum(2);
  return {value, slope};
}

// Lower bound of min_s Φ_j for every anchor from tangents at sorted slopes s (B, m): where
// the subgradient changes sign between s_l and s_l+1 the minimum lies in between, above
// both tangents, so above their crossing. Returns (bound, crossing slope), both (B, n);
// -inf / NaN where the sign does not change within the slopes.
std::pair<at::Tensor, at::Tensor> tangent_bounds(const at::Tensor& s, const at::Tensor& value,
                                                 const at::Tensor& slope) {
  const double inf = std::numeric_limits<double>::infinity();
  at::Tensor lower = at::full_like(value.select(1, 0), -inf);
  at::Tensor crossing = at::full_like(lower, std::numeric_limits<double>::quiet_NaN());
  for (int64_t l = 0; l + 1 < s.size(1); ++l) {
    const at::Tensor f0 = value.select(1, l), f1 = value.select(1, l + 1);
    const at::Tensor d0 = slope.select(1, l), d1 = slope.select(1, l + 1);
    const at::Tensor s0 = s.select(1, l).unsqueeze(-1), s1 = s.select(1, l + 1).unsqueeze(-1);
    const at::Tensor bracket = at::logical_and(d0 <= 0, d1 >= 0);
    const at::Tensor denominator = d1 - d0;
    const at::Tensor safe = at::where(denominator > 0, denominator, at::ones_like(denominator));
    const at::Tensor x =
        at::where(denominator > 0, (f0 - f1 - d0 * s0 + d1 * s1) / safe, s0.expand_as(f0));
    const at::Tensor bound = at::where(denominator > 0, f0 + d0 * (x - s0), at::minimum(f0, f1));
    const at::Tensor tighter = at::logical_and(bracket, bound > lower);
    lower = at::where(tighter, bound, lower);
    crossing = at::where(tighter, x, crossing);
  }
  return {lower, crossing};
}

// Exact anchored search with pruning. Each Φ_j is convex in s, so tangents bound min Φ_j
// from below (tangent_bounds) and evaluations bound the overall optimum from above. Only
// anchors whose lower bound does not exceed the best evaluation can win. The slopes start
// spread around the unrestricted optimum (which the anchored ones cluster about) and are
// refined where the surviving anchors' minima lie; the survivors get the exact fit, best
// bound first, until no bound is below the best loss found.
AffineFit pruned_anchored_search(const at::Tensor& X, const at::Tensor& Y, const at::Tensor& W) {
  constexpr int kRefinements = 3, kSlopesPerRefinement = 12;
  constexpr int64_t kFewCandidates = 32;
  const at::Tensor Xd = X.to(at::kDouble), Yd = Y.to(at::kDouble), Wd = W.to(at::kDouble);
  at::Tensor centre = pivot_descent(Xd, Yd, Wd).scale;
  centre = at::where(at::isfinite(centre), centre, at::ones_like(centre));
  const at::Tensor base = at::where(centre.abs() > 0, centre.abs(), at::ones_like(centre));
  const at::Tensor offsets =
      at::tensor({-10.0, -3.0, -1.0, -0.3, -0.1, -0.03, -1e-2, -3e-3, -1e-3, -1e-4, 0.0,
                  1e-4,  1e-3, 3e-3, 1e-2, 0.03, 0.1,   0.3,   1.0,   3.0,   10.0},
                 Xd.options());
  at::Tensor s = centre.unsqueeze(1) + base.unsqueeze(1) * offsets.unsqueeze(0);  // (B, m)
  at::Tensor value, slope, lower, crossing, candidates;
  std::tie(value, slope) = anchored_objectives(Xd, Yd, Wd, s);
  for (int round = 0;; ++round) {
    std::tie(lower, crossing) = tangent_bounds(s, value, slope);
    const at::Tensor upper = value.amin({1, 2}).unsqueeze(-1);  // (B, 1)
    // Keep anchors within rounding of the bound, so the test errs on the side of solving.
    candidates = lower <= upper + 1e-9 * upper.abs();
    if (round == kRefinements || candidates.sum(-1).max().item<int64_t>() <= kFewCandidates) break;
    // New slopes at quantiles of the candidates' tangent crossings, where their minima lie.
    const at::Tensor q = at::linspace(0.0, 1.0, kSlopesPerRefinement, Xd.options());
    const at::Tensor at_candidates =
        at::where(at::logical_and(candidates, at::isfinite(crossing)), crossing,
                  at::full({}, std::numeric_limits<double>::quiet_NaN(), Xd.options()));
    at::Tensor extra = at::nanquantile(at_candidates, q, -1).t();  // (B, K)
    extra = at::where(at::isfinite(extra), extra, centre.unsqueeze(1));
    at::Tensor extra_value, extra_slope;
    std::tie(extra_value, extra_slope) = anchored_objectives(Xd, Yd, Wd, extra);
    at::Tensor order;
    std::tie(s, order) = at::cat({s, extra}, 1).sort(1);
    const at::Tensor index = order.unsqueeze(-1).expand({-1, -1, value.size(2)});
    value = at::cat({value, extra_value}, 1).gather(1, index);
    slope = at::cat({slope, extra_slope}, 1).gather(1, index);
  }
  return anchored_search(X, Y, W, candidates, lower);
}

// No lower bound for any anchor of (B, C, n) samples: the exhaustive search.
at::Tensor unbounded(const at::Tensor& X) {
  return at::full({X.size(0), X.size(2)}, -std::numeric_limits<double>::infinity(),
                  X.options().dtype(at::kDouble));
}

// The number of batch items of samples with `sample_dims` trailing sample dimensions.
int64_t batch_count(const at::Tensor& t, int64_t sample_dims) {
  int64_t count = 1;
  for (int64_t i = 0; i < t.dim() - sample_dims; ++i) count *= t.size(i);
  return count;
}

// Flattens (..., n) samples into (B, 1, n) rows.
std::tuple<at::Tensor, at::Tensor, at::Tensor> depth_rows(const at::Tensor& x, const at::Tensor& y,
                                                          const at::Tensor& weight,
                                                          const at::Tensor& mask) {
  check_inputs(x, y, weight, mask);
  at::Tensor xs, ys, ws;
  std::tie(xs, ys, ws) = sanitize(x, y, weight, mask);
  const int64_t n = x.size(-1);
  const int64_t b = batch_count(x, 1);
  return {pad_empty(xs.reshape({b, 1, n})), pad_empty(ys.reshape({b, 1, n})),
          pad_empty(ws.reshape({b, 1, n}))};
}

// Points (..., n, 3) with weight (..., n) into (B, 3, n) axis rows.
std::tuple<at::Tensor, at::Tensor, at::Tensor> points_rows(const at::Tensor& source,
                                                           const at::Tensor& target,
                                                           const at::Tensor& weight,
                                                           const at::Tensor& mask) {
  check_same_shape(source, target, "source points", "target points");
  if (source.dim() < 2 || source.size(-1) != 3) {
    throw std::invalid_argument("alignment: points must have shape (..., n, 3)");
  }
  const at::Tensor w3 = weight.unsqueeze(-1).expand_as(source);
  const at::Tensor m3 = mask.defined() ? mask.unsqueeze(-1).expand_as(source) : at::Tensor();
  check_inputs(source, target, w3, m3);
  at::Tensor xs, ys, ws;
  std::tie(xs, ys, ws) = sanitize(source, target, w3, m3);
  const int64_t n = source.size(-2);
  const int64_t b = batch_count(source, 2);
  auto rows = [n, b](const at::Tensor& t) {
    return pad_empty(t.reshape({b, n, 3}).transpose(1, 2).contiguous());
  };
  return {rows(xs), rows(ys), rows(ws)};
}

std::vector<int64_t> batch_shape_of(const at::Tensor& t, int64_t sample_dims) {
  return t.sizes().slice(0, t.dim() - sample_dims).vec();
}

AffineFit reshape_affine(const AffineFit& fit, const std::vector<int64_t>& batch_shape,
                         bool points) {
  std::vector<int64_t> shift_shape = batch_shape;
  if (points) shift_shape.push_back(3);
  return {fit.scale.reshape(batch_shape), fit.shift.reshape(shift_shape),
          fit.loss.reshape(batch_shape)};
}

}  // namespace

ScaleFit fit_scale_l1(const at::Tensor& x, const at::Tensor& y, const at::Tensor& weight,
                      const at::Tensor& mask) {
  check_inputs(x, y, weight, mask);
  at::Tensor xs, ys, ws;
  std::tie(xs, ys, ws) = sanitize(x, y, weight, mask);
  const int64_t n = x.size(-1);
  const int64_t b = batch_count(x, 1);
  auto rows = [n, b](const at::Tensor& t) { return pad_empty(t.reshape({b, n})); };
  return reshape_fit(scale_fit_rows(rows(xs), rows(ys), rows(ws)), batch_shape_of(x, 1));
}

at::Tensor fit_scale_to_sparse_depth(const at::Tensor& x, const at::Tensor& y,
                                     const at::Tensor& mask) {
  check_same_shape(x, y, "prediction", "sparse depth");
  at::Tensor usable = at::isfinite(y) & (y > 0) & at::isfinite(x) & (x > 0);
  if (mask.defined()) usable = usable & mask;
  const at::Tensor weight = at::where(usable, y.reciprocal(), at::zeros_like(y));
  const at::Tensor scale = fit_scale_l1(x, y, weight, usable).scale;
  return at::where(usable.any(-1), scale, at::ones_like(scale));
}

ScaleFit fit_scale_l1_truncated(const at::Tensor& x, const at::Tensor& y, const at::Tensor& weight,
                                double trunc, const at::Tensor& mask) {
  if (!(trunc > 0)) throw std::invalid_argument("alignment: trunc must be positive");
  check_inputs(x, y, weight, mask);
  at::Tensor xs, ys, ws;
  std::tie(xs, ys, ws) = sanitize(x, y, weight, mask);
  const int64_t n = x.size(-1);
  const int64_t b = batch_count(x, 1);
  auto rows = [n, b](const at::Tensor& t) { return pad_empty(t.reshape({b, n})); };
  return reshape_fit(truncated_scale_fit_rows(rows(xs), rows(ys), rows(ws), trunc),
                     batch_shape_of(x, 1));
}

AffineFit fit_affine_l1(const at::Tensor& x, const at::Tensor& y, const at::Tensor& weight,
                        const at::Tensor& mask) {
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = depth_rows(x, y, weight, mask);
  AffineFit fit = pivot_descent(X, Y, W);
  fit.shift = fit.shift.squeeze(-1);
  return reshape_affine(fit, batch_shape_of(x, 1), false);
}

AffineFit fit_affine_l1_brute_force(const at::Tensor& x, const at::Tensor& y,
                                    const at::Tensor& weight, const at::Tensor& mask) {
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = depth_rows(x, y, weight, mask);
  const at::Tensor all = at::ones({X.size(0), X.size(2)}, X.options().dtype(at::kBool));
  AffineFit fit = anchored_search(X, Y, W, all, unbounded(X));
  fit.shift = fit.shift.squeeze(-1);
  return reshape_affine(fit, batch_shape_of(x, 1), false);
}

ScaleFit fit_points_scale_l1(const at::Tensor& source, const at::Tensor& target,
                             const at::Tensor& weight, const at::Tensor& mask, double trunc) {
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = points_rows(source, target, weight, mask);
  const ScaleFit fit =
      trunc > 0 ? truncated_scale_fit_rows(X.flatten(1), Y.flatten(1), W.flatten(1), trunc)
                : scale_fit_rows(X.flatten(1), Y.flatten(1), W.flatten(1));
  // Report the index into the (n, 3) layout of the input.
  const int64_t n = X.size(2);
  const at::Tensor index =
      at::where(fit.index >= 0, (fit.index % n) * 3 + fit.index.div(n, "floor"), fit.index);
  return reshape_fit({fit.scale, fit.loss, index}, batch_shape_of(source, 2));
}

at::Tensor fit_points_shift_l1(const at::Tensor& source, const at::Tensor& target,
                               const at::Tensor& weight, const at::Tensor& mask) {
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = points_rows(source, target, weight, mask);
  const at::Tensor ones = at::where(W > 0, at::ones_like(X), at::zeros_like(X));
  const at::Tensor shift = scale_fit_rows(ones, Y - X, W).scale;  // (B, 3)
  std::vector<int64_t> shape = batch_shape_of(source, 2);
  shape.push_back(3);
  return shift.reshape(shape);
}

AffineFit fit_points_affine_l1(const at::Tensor& source, const at::Tensor& target,
                               const at::Tensor& weight, const at::Tensor& mask) {
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = points_rows(source, target, weight, mask);
  return reshape_affine(pivot_descent(X, Y, W), batch_shape_of(source, 2), true);
}

AffineFit fit_points_affine_l1_anchored(const at::Tensor& source, const at::Tensor& target,
                                        const at::Tensor& weight, const at::Tensor& mask) {
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = points_rows(source, target, weight, mask);
  return reshape_affine(pruned_anchored_search(X, Y, W), batch_shape_of(source, 2), true);
}

AffineFit fit_points_affine_l1_anchored_brute_force(const at::Tensor& source,
                                                    const at::Tensor& target,
                                                    const at::Tensor& weight,
                                                    const at::Tensor& mask) {
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = points_rows(source, target, weight, mask);
  const at::Tensor all = at::ones({X.size(0), X.size(2)}, X.options().dtype(at::kBool));
  return reshape_affine(anchored_search(X, Y, W, all, unbounded(X)), batch_shape_of(source, 2),
                        true);
}

AffineFit fit_points_scale_z_shift_l1_truncated(const at::Tensor& source, const at::Tensor& target,
                                                const at::Tensor& weight, double trunc,
                                                const at::Tensor& mask) {
  if (!(trunc > 0)) throw std::invalid_argument("alignment: trunc must be positive");
  at::Tensor X, Y, W;
  std::tie(X, Y, W) = points_rows(source, target, weight, mask);
  const int64_t batch = X.size(0), n = X.size(2);
  const double inf = std::numeric_limits<double>::infinity();
  const int64_t max_chunk = std::max<int64_t>(1, kMaxElementsPerChunk / (3 * n));
  const at::Tensor z_only = at::tensor({0.0, 0.0, 1.0}, X.options()).view({1, 3, 1});
  std::vector<at::Tensor> scales, shifts;
  for (int64_t b = 0; b < batch; ++b) {
    const at::Tensor xb = X[b], yb = Y[b], w_row = W[b].flatten().unsqueeze(0);
    const at::Tensor anchors = (W[b][2] > 0).nonzero().flatten();
    double best_loss = inf;
    at::Tensor best_scale = at::full({}, std::numeric_limits<double>::quiet_NaN(), X.options());
    at::Tensor best_shift = at::full({}, std::numeric_limits<double>::quiet_NaN(), X.options());
    for (int64_t start = 0; start < anchors.numel(); start += max_chunk) {
      const at::Tensor ids = anchors.narrow(0, start, std::min(max_chunk, anchors.numel() - start));
      const at::Tensor px = xb[2].index_select(0, ids).view({-1, 1, 1}),
                       gz = yb[2].index_select(0, ids).view({-1, 1, 1});
      const at::Tensor x_rel = (xb.unsqueeze(0) - z_only * px).flatten(1);
      const at::Tensor y_rel = (yb.unsqueeze(0) - z_only * gz).flatten(1);
      const ScaleFit fit = truncated_scale_fit_rows(x_rel, y_rel, w_row.expand_as(x_rel), trunc);
      const at::Tensor loss =
          at::where(at::isnan(fit.loss), at::full({}, inf, fit.loss.options()), fit.loss);
      const int64_t i = loss.argmin().item<int64_t>();
      if (loss[i].item<double>() < best_loss) {
        best_loss = loss[i].item<double>();
        best_scale = fit.scale[i];
        best_shift = gz.flatten()[i] - fit.scale[i] * px.flatten()[i];
      }
    }
    scales.push_back(best_scale);
    shifts.push_back(
        at::stack({at::zeros_like(best_shift), at::zeros_like(best_shift), best_shift}));
  }
  const at::Tensor scale = at::stack(scales), shift = at::stack(shifts);
  const at::Tensor loss = (W * (scale.view({-1, 1, 1}) * X + shift.unsqueeze(-1) - Y).abs())
                              .clamp_max(trunc)
                              .sum({-2, -1});
  return reshape_affine({scale, shift, loss}, batch_shape_of(source, 2), true);
}

}  // namespace omnipoint::geometry
