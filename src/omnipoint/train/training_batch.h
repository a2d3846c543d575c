#pragma once
// One training item made from a dataset's sample (the stage's augmentations and conditions,
// batch_source.h says which and when), and the collation of items into the batch a step
// trains on.
#include <ATen/core/Tensor.h>
#include <c10/core/Device.h>

#include <cstdint>
#include <vector>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/train/losses.h"
#include "omnipoint/train/train_config.h"

namespace omnipoint::data {
struct Sample;
}
namespace omnipoint::data::synth {
class Random;
}

namespace omnipoint::train {

struct TrainingItem {
  at::Tensor image;            // (3,H,W) RGB in [0,1]
  at::Tensor rays;             // (H,W,3) GT unit rays, zero where the camera is invalid
  at::Tensor distance;         // (H,W) GT distances, 0 where unlabelled
  at::Tensor mask;             // (H,W) bool: labelled geometry
  at::Tensor mask_negative;    // (H,W) bool: known to hold no geometry (sky)
  at::Tensor metric;           // () bool: the distances are metric
  at::Tensor sparse;           // () bool: sparse labels (data::Sample::sparse_labels)
  at::Tensor condition_rays;   // (3,H,W) GT rays where the condition is on, else 0
  at::Tensor condition_depth;  // (H,W) sparse GT distances where on, else 0
};

struct TrainingBatch {
  at::Tensor image;                   // (B,3,H,W) RGB in [0,1]
  at::Tensor condition_rays;          // (B,3,H,W) GT rays where the condition is on, else 0
  at::Tensor condition_sparse_depth;  // (B,H,W) sparse GT distances where on, else 0
  LossTargets targets;
  int64_t num_tokens = 0;  // token budget of this step (the same on every rank)
};

// What decides an item beyond its sample.
struct ItemContext {
  const TrainConfig* config = nullptr;        // augmentations, condition probability, ...
  bool conditions = false;                    // stages 2 and 3: conditions and P2A/A2P may be on
  bool labelled = true;                       // false: the source has no labels (A2P's alone)
  const augment::Teacher* teacher = nullptr;  // A2P's, where the config enables it
};

// The sample (at the batch's size) as a training item: P2A or A2P, photometric augmentation,
// mirroring and the conditions, each drawn from `random` only where enabled (so a config
// without them sees the same items).
TrainingItem make_training_item(const data::Sample& sample, const ItemContext& context,
                                data::synth::Random& random);

// The items (of one size) stacked into a batch.
TrainingBatch collate(const std::vector<TrainingItem>& items, int64_t num_tokens);

// The batch's tensors on `device` (undefined ones stay undefined).
TrainingBatch to_device(const TrainingBatch& batch, at::Device device);

}  // namespace omnipoint::train
