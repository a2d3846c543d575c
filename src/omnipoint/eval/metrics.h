#pragma once
// MoGe's evaluation protocol for one image (tests/fixtures/README.md §2.3–2.4).
//
// Entries, each scored by `rel` and `delta1` over all valid full-resolution pixels:
//   depth_metric, depth_scale_invariant, depth_affine_invariant, disparity_affine_invariant,
//   points_metric, points_scale_invariant, points_affine_invariant.
// Depth: rel = mean |p − g| / (g + 1e-6), delta1 = mean(max(g/p, p/g) < 1.25).
// Points: rel = mean ‖p − g‖ / (‖g‖ + 1e-6), delta1 = mean(‖p − g‖ < 0.25·min(‖g‖, ‖p‖)).
// Alignments (except disparity) are fitted on the mask-aware 64×64 subsample with weights
// 1/g (depth) or 1/‖g‖ (points). Metric entries exist only when both the ground truth and
// the prediction are metric; point entries only when both point maps are given.
// An entry that is undefined for the input (empty mask, invalid ground truth, NaN/inf in the
// prediction, a degenerate fit) is NaN and a warning says why; nothing is printed here.
#include <ATen/core/Tensor.h>

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace omnipoint::eval {

// The protocol's entries, in MoGe's order.
extern const std::array<const char*, 7> kMetricEntries;

// MoGe's mask-aware nearest subsample of an (H, W) bool mask to size × size cells: each cell
// takes the valid pixel nearest its centre within a ceil(H/size) × ceil(W/size) window.
struct Subsample {
  at::Tensor index;  // (2, size, size) int64: [row, col] of the picked pixel (0 where empty)
  at::Tensor mask;   // (size, size) bool: whether the cell found a valid pixel
};
Subsample mask_aware_subsample(const at::Tensor& mask, int64_t size = 64);

struct GroundTruth {
  at::Tensor depth;   // (H, W)
  at::Tensor points;  // (H, W, 3), optional
  at::Tensor mask;    // (H, W) bool: valid pixels
  bool is_metric = false;
};

struct Prediction {
  at::Tensor depth;   // (H, W), optional
  at::Tensor points;  // (H, W, 3), optional
  bool is_metric = false;
};

struct Score {
  double rel;
  double delta1;
};

// The fitted alignment of an entry (NaN / empty where the entry has none).
struct Alignment {
  double scale;
  std::vector<double> shift;   // 1 value for depth, 3 for points
  double clamp_min_disparity;  // disparity_affine_invariant only
};

struct Metrics {
  std::map<std::string, Score> entries;
  std::map<std::string, Alignment> alignment;
  std::vector<std::string> warnings;
  int64_t num_valid_pixels = 0;
  int64_t num_lowres_samples = 0;
};

// Throws std::invalid_argument for inconsistent shapes or dtypes; never for bad values.
Metrics compute_metrics(const Prediction& prediction, const GroundTruth& ground_truth);

// MoGe's key_average over instances: each entry is averaged over the instances that have it;
// NaN entries are excluded from the mean and counted.
struct AveragedScore {
  double rel;
  double delta1;
  int64_t count;     // instances averaged
  int64_t excluded;  // instances whose entry was NaN
};
std::map<std::string, AveragedScore> average_metrics(const std::vector<Metrics>& instances);

}  // namespace omnipoint::eval
