#pragma once
// Training batches as a pure function of (seed, step, rank): item k of step s on rank r is
// global item s·B·world + r·B + k, and every random choice for it (data source by weight,
// scene, camera, sample, condition drop, sparse samples) is drawn from counter-based
// generators keyed by that index. The "data position" of a run is therefore its step alone:
// a resumed run sees exactly the batches the uninterrupted one would have seen, and ranks
// read disjoint shards of the same global batch.
//
// Aspect-ratio buckets: the sources of one image size form a bucket. Each step draws one
// bucket (the same on every rank), with the summed weight of its sources, and its items come
// from those sources by weight, at that size (folder samples centre-cropped to the aspect and
// resized; synthetic cameras resized). So panoramas train at 2:1 while pinholes train at 4:3.
// Unlabelled sources ("labels": false) take part only where A2P pseudo-labels them (stage 2
// on, augment.a2p); A2P never replaces an exact label except with a2p_probability (the
// paper's preset) on labelled wide items.
//
// Bidirectional augmentation (paper §3.4), from stage 2 on, when the config enables it:
// - P2A: a perspective item (camera::CameraClass) is, with p2a_probability, rendered into a
//   random virtual fisheye or panorama (augment::sample_virtual_view, resized to the training
//   size) by augment::perspective_to_any: its image, rays, distances and mask.
// - A2P: a wide-FoV item (fisheye or panorama) is, with a2p_probability, treated as
//   unlabelled: one random pinhole view of it goes through the teacher (an OmniPoint
//   checkpoint, e.g. the stage-1 model, with the view's rays as intrinsics) and the
//   prediction, stitched back, replaces its labels (augment::any_to_perspective). Pseudo-
//   labels count as non-metric, and its sparse-depth condition is drawn from them, since an
//   unlabelled image has no other depth.
// Both leave unlabelled pixels unknown: they are not mask-head negatives (sky), unlike the
// camera-valid unlabelled pixels of a labelled sample.
// Then, in every stage when enabled: photometric augmentation of the image, and a mirror
// image (image, labels and the rays' x mirrored together) for half of the items.
#include <ATen/core/Tensor.h>
#include <c10/core/Device.h>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/train/losses.h"
#include "omnipoint/train/train_config.h"

namespace omnipoint::train {

struct TrainingBatch {
  at::Tensor image;                   // (B,3,H,W) RGB in [0,1]
  at::Tensor condition_rays;          // (B,3,H,W) GT rays where the condition is on, else 0
  at::Tensor condition_sparse_depth;  // (B,H,W) sparse GT distances where on, else 0
  LossTargets targets;
  int64_t num_tokens = 0;  // token budget of this step (the same on every rank)
};

// The batch's tensors on `device` (undefined ones stay undefined).
TrainingBatch to_device(const TrainingBatch& batch, at::Device device);

class BatchSource {
 public:
  // Folder datasets are listed and the A2P teacher is loaded here (std::runtime_error for a
  // missing or empty directory or an unreadable teacher).
  explicit BatchSource(const TrainConfig& config);

  // `conditions`: whether the conditions may be on (stages 2 and 3). `stream` separates
  // independent sequences of the same seed (0 training, 1 evaluation). `bucket` >= 0 takes
  // the bucket of that index (modulo their number; the next one with usable sources) instead
  // of drawing one, so that an evaluation covers every bucket.
  TrainingBatch batch(int64_t step, bool conditions, int64_t rank = 0, int64_t world_size = 1,
                      uint64_t stream = 0, int64_t bucket = -1) const;

  int64_t bucket_count() const { return static_cast<int64_t>(buckets_.size()); }

 private:
  struct Bucket {
    int64_t width = 0, height = 0;
    std::vector<size_t> sources;  // indices into config_.datasets
  };
  // A source's weight in this step: 0 for an unlabelled one unless A2P can label it.
  double source_weight(size_t source, bool conditions) const;
  double bucket_weight(const Bucket& bucket, bool conditions) const;

  TrainConfig config_;
  std::vector<std::vector<std::string>> folders_;  // per dataset source: its sample folders
  std::vector<Bucket> buckets_;                    // in the order the sizes first appear
  augment::Teacher teacher_;                       // A2P's, when enabled
};

// A seed for a CPU generator derived from (seed, stream, index) by SplitMix64 mixing.
uint64_t derived_seed(uint64_t seed, uint64_t stream, uint64_t index);

}  // namespace omnipoint::train
