#pragma once
// Training batches as a pure function of (seed, step, rank): item k of step s on rank r is
// global item s·B·world + r·B + k, and every random choice for it (data source by weight,
// scene, camera, sample, condition drop, sparse samples) is drawn from counter-based
// generators keyed by that index. The "data position" of a run is therefore its step alone:
// a resumed run sees exactly the batches the uninterrupted one would have seen, and ranks
// read disjoint shards of the same global batch.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/train/losses.h"
#include "omnipoint/train/train_config.h"

namespace omnipoint::train {

struct TrainingBatch {
  at::Tensor image;                   // (B,3,H,W) RGB in [0,1]
  at::Tensor condition_rays;          // (B,3,H,W) GT rays where the condition is on, else 0
  at::Tensor condition_sparse_depth;  // (B,H,W) sparse GT distances where on, else 0
  LossTargets targets;
  int64_t num_tokens = 0;             // token budget of this step (the same on every rank)
};

class BatchSource {
 public:
  // Folder datasets are listed here (std::runtime_error for a missing or empty directory).
  explicit BatchSource(const TrainConfig& config);

  // `conditions`: whether the conditions may be on (stages 2 and 3). `stream` separates
  // independent sequences of the same seed (0 training, 1 evaluation).
  TrainingBatch batch(int64_t step, bool conditions, int64_t rank = 0, int64_t world_size = 1,
                      uint64_t stream = 0) const;

 private:
  TrainConfig config_;
  std::vector<std::vector<std::string>> folders_;  // per dataset source: its sample folders
  double total_weight_ = 0;
};

// A seed for a CPU generator derived from (seed, stream, index) by SplitMix64 mixing.
uint64_t derived_seed(uint64_t seed, uint64_t stream, uint64_t index);

}  // namespace omnipoint::train
