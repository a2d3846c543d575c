#include "omnipoint/predict/rig_overlap.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include "omnipoint/predict/median.h"

namespace omnipoint::predict {

namespace {

using at::indexing::Slice;

// A camera's pose split once: rotation (3, 3) and centre (3) in the body frame, float64.
struct Pose {
  at::Tensor rotation, centre;
};

Pose split_pose(const at::Tensor& body_from_camera) {
  const at::Tensor m = body_from_camera.to(at::kDouble);
  return {m.index({Slice(0, 3), Slice(0, 3)}), m.index({Slice(0, 3), 3})};
}

// The log ratios of one directed pair's overlapping pixels: camera j's valid points, at factor
// fj, seen by camera i at factor fi (see the header). Empty when nothing overlaps.
at::Tensor pair_log_ratios(const OverlapCamera& ci, const Pose& pi, double fi,
                           const OverlapCamera& cj, const Pose& pj, double fj, double band) {
  const at::Tensor mask_j = cj.mask.to(at::kBool);
  const at::Tensor in_j = cj.rays.to(at::kDouble).index({mask_j}) *
                          (cj.distance.to(at::kDouble).index({mask_j}) * fj).unsqueeze(-1);
  if (in_j.size(0) == 0) return at::empty({0}, at::kDouble);
  const at::Tensor body = in_j.matmul(pj.rotation.t()) + pj.centre;
  at::Tensor in_i = (body - pi.centre).matmul(pi.rotation);  // Rᵢᵀ (p − cᵢ), row by row
  const camera::Pixels projected = ci.camera.project(in_i);
  const int64_t height = ci.distance.size(0), width = ci.distance.size(1);
  const at::Tensor u = projected.pixels.select(-1, 0) - 0.5;  // pixel centres at i + 0.5
  const at::Tensor v = projected.pixels.select(-1, 1) - 0.5;
  const at::Tensor x0 = u.floor(), y0 = v.floor();
  const at::Tensor lands = projected.valid & (x0 >= 0) & (x0 <= width - 2) & (y0 >= 0) &
                           (y0 <= height - 2) & (in_i.norm(2, -1) > 0);
  const at::Tensor keep = lands.nonzero().squeeze(1);
  if (keep.numel() == 0) return at::empty({0}, at::kDouble);
  in_i = in_i.index({keep});
  const at::Tensor fx = (u.index({keep}) - x0.index({keep})).unsqueeze(-1);
  const at::Tensor fy = (v.index({keep}) - y0.index({keep})).unsqueeze(-1);
  const at::Tensor col = x0.index({keep}).to(at::kLong), row = y0.index({keep}).to(at::kLong);

  const at::Tensor distance_i = ci.distance.to(at::kDouble).reshape({-1}) * fi;
  const at::Tensor points_i = ci.rays.to(at::kDouble).reshape({-1, 3}) * distance_i.unsqueeze(-1);
  const at::Tensor mask_i = ci.mask.to(at::kBool).reshape({-1});
  at::Tensor corners_valid = at::ones({keep.size(0)}, at::kBool);
  at::Tensor near = at::full({keep.size(0)}, INFINITY, at::kDouble);
  at::Tensor far = at::zeros({keep.size(0)}, at::kDouble);
  std::vector<at::Tensor> corner;  // (N, 3) points of i at (x0, y0), (x0+1, y0), (x0, y0+1), ..
  for (int dy = 0; dy < 2; ++dy) {
    for (int dx = 0; dx < 2; ++dx) {
      const at::Tensor index = (row + dy) * width + (col + dx);
      const at::Tensor d = distance_i.index({index});
      corners_valid = corners_valid & mask_i.index({index});
      near = at::minimum(near, d);
      far = at::maximum(far, d);
      corner.push_back(points_i.index({index}));
    }
  }
  // i's surface there: the triangle of the pixel's corners the point falls in (split along the
  // diagonal), met by the ray from i's centre through j's point — exact on a plane, wherever in
  // the pixel the point lands.
  const at::Tensor lower = (fx + fy <= 1).expand({-1, 3});
  const at::Tensor p0 = at::where(lower, corner[0], corner[3]);
  const at::Tensor n = at::cross(corner[1] - p0, corner[2] - p0, -1);
  const at::Tensor seen = in_i.norm(2, -1);
  const at::Tensor direction = in_i / seen.unsqueeze(-1);
  const at::Tensor facing = (n * direction).sum(-1);
  const at::Tensor surface = (n * p0).sum(-1) / facing;
  // No depth edge between the four pixels (their distances within the band of each other), and
  // not a surface seen edge-on (the triangle within 85 degrees of facing the ray).
  const at::Tensor usable = corners_valid & (near > 0) & (far.log() - near.log() <= band) &
                            (facing.abs() > 0.087 * n.norm(2, -1)) & (surface > 0);
  return surface.index({usable}).log() - seen.index({usable}).log();
}

// A pair's log ratio: the median over the pixels within the band of the first median.
struct PairMeasure {
  int64_t pixels = 0, inliers = 0;
  double log_ratio = 0;
  double spread = 0;  // 1.4826 x the inliers' median absolute deviation from log_ratio
  at::Tensor ratios;  // the pixels' log ratios
};

PairMeasure measure(const at::Tensor& ratios, double band) {
  PairMeasure m;
  m.ratios = ratios;
  m.pixels = ratios.numel();
  if (m.pixels == 0) return m;
  const double first = ratios.median().item<double>();
  const at::Tensor within = ratios.index({(ratios - first).abs() <= band});
  m.inliers = within.numel();
  m.log_ratio = m.inliers > 0 ? within.median().item<double>() : first;
  if (m.inliers > 0) m.spread = 1.4826 * (within - m.log_ratio).abs().median().item<double>();
  return m;
}

// Pair (i, j) at the log factors so far.
PairMeasure measure_pair(const std::vector<OverlapCamera>& cameras, const std::vector<Pose>& poses,
                         const std::vector<double>& log_factor, size_t i, size_t j, double band) {
  return measure(pair_log_ratios(cameras[i], poses[i], std::exp(log_factor[i]), cameras[j],
                                 poses[j], std::exp(log_factor[j]), band),
                 band);
}

// A pair's standard error (log). Its pixels' errors are correlated by rho: a part common to all of
// them (the network's error over the region, rho of the variance) that their spread does not show,
// and a part of their own (1 - rho: what the spread shows) that averages out over n pixels.
double pair_sigma(const PairMeasure& m, const OverlapOptions& options) {
  const double n = static_cast<double>(std::max<int64_t>(m.inliers, 1));
  const double rho = options.pixel_correlation;
  return std::max(m.spread, kOverlapMinSpread) * std::sqrt(rho / (1 - rho) + 1 / n);
}

// `weights`: the pairs' robust weights (empty: 1 each).
void finish(const std::vector<OverlapCamera>& cameras, const std::vector<Pose>& poses,
            const std::vector<double>& log_factor,
            const std::vector<std::pair<size_t, size_t>>& counted, const OverlapOptions& options,
            const std::vector<double>& weights, OverlapResult& result) {
  std::vector<at::Tensor> deviations;
  for (size_t k = 0; k < counted.size(); ++k) {
    const auto [i, j] = counted[k];
    const PairMeasure m = measure_pair(cameras, poses, log_factor, i, j, options.band);
    OverlapPair pair;
    pair.i = i;
    pair.j = j;
    pair.pixels = m.pixels;
    pair.inliers = m.inliers;
    pair.log_ratio = m.log_ratio;
    pair.spread = m.spread;
    pair.sigma = pair_sigma(m, options);
    pair.weight = weights.empty() ? 1.0 : weights[k];
    if (m.pixels > 0) {
      const at::Tensor deviation = (m.ratios.exp() - 1).abs();
      pair.residual = deviation.median().item<double>();
      deviations.push_back(deviation);
    }
    result.pairs.push_back(pair);
  }
  result.factors.resize(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) result.factors[c] = std::exp(log_factor[c]);
  if (!deviations.empty()) result.residual = at::cat(deviations).median().item<double>();
}

int find_root(std::vector<int>& parent, int a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

}  // namespace

void OverlapOptions::Check() const {
  if (min_pixels < 1)
    throw std::invalid_argument("overlap: min_pixels " + std::to_string(min_pixels) +
                                ": expected >= 1");
  if (!(band > 0) || !std::isfinite(band))
    throw std::invalid_argument("overlap: band " + std::to_string(band) + ": expected > 0");
  if (free_group_scale && !(*free_group_scale > 0 && std::isfinite(*free_group_scale)))
    throw std::invalid_argument("overlap: free_group_scale " + std::to_string(*free_group_scale) +
                                ": expected > 0");
  if (!(prior_sigma > 0) || !std::isfinite(prior_sigma))
    throw std::invalid_argument("overlap: prior_sigma " + std::to_string(prior_sigma) +
                                ": expected > 0");
  if (!(pixel_correlation >= 0 && pixel_correlation < 1))
    throw std::invalid_argument("overlap: pixel_correlation " + std::to_string(pixel_correlation) +
                                ": expected in [0, 1)");
  if (!(huber > 0) || !std::isfinite(huber))
    throw std::invalid_argument("overlap: huber " + std::to_string(huber) + ": expected > 0");
  if (max_iterations < 1)
    throw std::invalid_argument("overlap: max_iterations " + std::to_string(max_iterations) +
                                ": expected >= 1");
  if (!(tolerance > 0)) throw std::invalid_argument("overlap: tolerance: expected > 0");
}

namespace {

// The poses of valid cameras (std::invalid_argument otherwise).
std::vector<Pose> checked_poses(const std::vector<OverlapCamera>& cameras) {
  std::vector<Pose> poses;
  for (const OverlapCamera& c : cameras) {
    if (c.distance.dim() != 2 || c.distance.size(0) != c.camera.height() ||
        c.distance.size(1) != c.camera.width() || c.mask.sizes() != c.distance.sizes() ||
        c.rays.dim() != 3 || c.rays.size(0) != c.distance.size(0) ||
        c.rays.size(1) != c.distance.size(1) || !(c.scale > 0))
      throw std::invalid_argument(
          "overlap: a camera's distance, mask and rays must be (H, W) at its camera's size and "
          "its scale > 0");
    poses.push_back(split_pose(c.body_from_camera));
  }
  return poses;
}

// The directed pairs that count at the cameras' current scales (>= min_pixels within the band).
std::vector<std::pair<size_t, size_t>> counted_pairs(const std::vector<OverlapCamera>& cameras,
                                                     const std::vector<Pose>& poses,
                                                     const OverlapOptions& options) {
  std::vector<std::pair<size_t, size_t>> counted;
  for (size_t i = 0; i < cameras.size(); ++i)
    for (size_t j = 0; j < cameras.size(); ++j)
      if (i != j &&
          measure_pair(cameras, poses, std::vector<double>(cameras.size(), 0.0), i, j, options.band)
                  .inliers >= options.min_pixels)
        counted.emplace_back(i, j);
  return counted;
}

}  // namespace

OverlapResult measure_overlaps(const std::vector<OverlapCamera>& cameras,
                               const OverlapOptions& options) {
  options.Check();
  const std::vector<Pose> poses = checked_poses(cameras);
  OverlapResult result;
  result.reconciled.assign(cameras.size(), false);
  result.group.assign(cameras.size(), -1);
  const std::vector<std::pair<size_t, size_t>> counted = counted_pairs(cameras, poses, options);
  finish(cameras, poses, std::vector<double>(cameras.size(), 0.0), counted, options, {}, result);
  return result;
}

OverlapResult reconcile_overlap_scales(const std::vector<OverlapCamera>& cameras,
                                       const OverlapOptions& options) {
  options.Check();
  const size_t n = cameras.size();
  const std::vector<Pose> poses = checked_poses(cameras);
  std::vector<double> log_factor(n, 0.0);
  // Which pairs count: measured once at the cameras' own scales.
  const std::vector<std::pair<size_t, size_t>> counted = counted_pairs(cameras, poses, options);

  OverlapResult result;
  result.factors.assign(n, 1.0);
  result.reconciled.assign(n, false);
  result.group.assign(n, -1);
  if (counted.empty()) {
    finish(cameras, poses, log_factor, counted, options, {}, result);
    return result;
  }

  // Groups of linked cameras; their anchors.
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  for (const auto& [i, j] : counted)
    parent[find_root(parent, static_cast<int>(i))] = find_root(parent, static_cast<int>(j));
  std::vector<bool> linked(n, false), group_anchored(n, false);
  for (const auto& [i, j] : counted) linked[i] = linked[j] = true;
  for (size_t c = 0; c < n; ++c) {
    if (!linked[c]) continue;
    result.group[c] = find_root(parent, static_cast<int>(c));
    if (cameras[c].anchored) group_anchored[result.group[c]] = true;
    result.reconciled[c] = !cameras[c].anchored;
  }
  std::vector<size_t> free_cameras;  // the unknowns
  for (size_t c = 0; c < n; ++c)
    if (result.reconciled[c]) free_cameras.push_back(c);

  // Levels a group without an anchor (the gauge): its median scale, or median correction.
  const auto level_free_groups = [&] {
    for (size_t root = 0; root < n; ++root) {
      if (group_anchored[root]) continue;
      std::vector<double> values;
      for (size_t c : free_cameras)
        if (result.group[c] == static_cast<int>(root))
          values.push_back(log_factor[c] +
                           (options.free_group_scale ? std::log(cameras[c].scale) : 0.0));
      if (values.empty()) continue;
      const double middle = median(std::move(values));
      const double target = options.free_group_scale ? std::log(*options.free_group_scale) : 0;
      for (size_t c : free_cameras)
        if (result.group[c] == static_cast<int>(root)) log_factor[c] += target - middle;
    }
  };

  std::vector<double> weights(counted.size(), 1.0);  // the pairs' robust weights
  if (!free_cameras.empty()) {
    // Unknowns: the free cameras' log factors, then one level per group that has free cameras
    // (the priors are relative to it).
    std::vector<int64_t> column(n, -1), level_column(n, -1);
    int64_t unknowns = 0;
    for (size_t c : free_cameras) column[c] = unknowns++;
    for (size_t c : free_cameras)
      if (level_column[result.group[c]] < 0) level_column[result.group[c]] = unknowns++;
    const int64_t rows = static_cast<int64_t>(counted.size() + free_cameras.size());
    level_free_groups();
    for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
      // Each pair asks log f_i - log f_j to move by -its log ratio (measured at the factors so
      // far), weighted by its inverse variance (half: both orders see the same overlap) and its
      // robust weight; each prior asks a camera's log factor to be its group's level.
      at::Tensor a = at::zeros({rows, unknowns}, at::kDouble);
      at::Tensor b = at::zeros({rows}, at::kDouble);
      std::vector<double> target(counted.size()), sigma(counted.size());
      for (size_t k = 0; k < counted.size(); ++k) {
        const auto [i, j] = counted[k];
        const PairMeasure m = measure_pair(cameras, poses, log_factor, i, j, options.band);
        target[k] = log_factor[i] - log_factor[j] - m.log_ratio;
        sigma[k] = pair_sigma(m, options);
        const double root_weight = std::sqrt(0.5 * weights[k]) / sigma[k];
        const auto row = static_cast<int64_t>(k);
        double rhs = target[k];
        if (column[i] >= 0)
          a[row][column[i]] = root_weight;
        else
          rhs -= log_factor[i];  // an anchor's factor is fixed (1)
        if (column[j] >= 0)
          a[row][column[j]] = -root_weight;
        else
          rhs += log_factor[j];
        b[row] = root_weight * rhs;
      }
      for (size_t k = 0; k < free_cameras.size(); ++k) {
        const size_t c = free_cameras[k];
        const auto row = static_cast<int64_t>(counted.size() + k);
        a[row][column[c]] = 1 / options.prior_sigma;
        a[row][level_column[result.group[c]]] = -1 / options.prior_sigma;
      }
      // Least squares, minimum norm: a group without an anchor keeps one free factor (the
      // pairs and priors are relative), set by level_free_groups.
      const at::Tensor solution = at::linalg_pinv(a).matmul(b);
      const std::vector<double> before = log_factor;
      for (size_t c : free_cameras) log_factor[c] = solution[column[c]].item<double>();
      level_free_groups();
      double largest = 0;
      for (size_t c : free_cameras)
        largest = std::max(largest, std::abs(log_factor[c] - before[c]));
      // Huber's weights from the pairs' residuals, in standard errors.
      for (size_t k = 0; k < counted.size(); ++k) {
        const auto [i, j] = counted[k];
        const double residual = std::abs(log_factor[i] - log_factor[j] - target[k]) / sigma[k];
        weights[k] = residual <= options.huber ? 1.0 : options.huber / residual;
      }
      if (largest < options.tolerance) break;
    }
  }

  finish(cameras, poses, log_factor, counted, options, weights, result);
  return result;
}

}  // namespace omnipoint::predict
