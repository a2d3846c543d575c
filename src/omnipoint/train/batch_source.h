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
// image (image, labels and the rays' x mirrored together) for half of the items
// (training_batch.h makes the item; its draws come after the source's and the sample's).
//
// The sources are datasets (data/dataset.h): a folder source is the "folders" format, a native
// one ("format", "root", "split", "options") the reader of its format (data::open_dataset), a
// synthetic one data::synth::SynthDataset. Items with sparse labels (Sample::sparse_labels:
// LiDAR) leave their unlabelled pixels unknown, not sky, and are flagged for the losses'
// sparse rules (losses.h). A bad sample (a folder that cannot be read or fails
// validation) does not stop a run: it is skipped with one warning (take_warnings) the first
// time it is met, counted by reason (skipped_samples), and the item draws another sample of the
// same source from its own generator, so the batch stays a function of (seed, step, rank)
// whatever was met before or on other threads. A source without any usable sample is an error
// (std::runtime_error naming it).
//
// Prefetch: prefetch() starts making a batch on a background thread; batch() with the same
// arguments then takes it (waiting for it if needed, rethrowing its error). A batch is the
// same whether prefetched or not and whatever the thread count: items are made whole on the
// intra-op threads (their own ops then run single-threaded), A2P's on the calling thread.
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/train/train_config.h"
#include "omnipoint/train/training_batch.h"

namespace omnipoint::data {
class Dataset;
struct Sample;
}  // namespace omnipoint::data

namespace omnipoint::train {

class BatchSource {
 public:
  // The sources' datasets are opened (folders listed, synthetic cameras read) and the A2P
  // teacher is loaded here (std::runtime_error for a missing or empty directory or an
  // unreadable teacher).
  explicit BatchSource(const TrainConfig& config);
  // Stops a prefetch in progress and waits for its thread.
  ~BatchSource();
  BatchSource(const BatchSource&) = delete;
  BatchSource& operator=(const BatchSource&) = delete;

  // `conditions`: whether the conditions may be on (stages 2 and 3). `stream` separates
  // independent sequences of the same seed (0 training, 1 evaluation). `bucket` >= 0 takes
  // the bucket of that index (modulo their number; the next one with usable sources) instead
  // of drawing one, so that an evaluation covers every bucket. Safe to call from several
  // threads at once.
  TrainingBatch batch(int64_t step, bool conditions, int64_t rank = 0, int64_t world_size = 1,
                      uint64_t stream = 0, int64_t bucket = -1) const;
  // Starts making batch(same arguments) on this source's background thread, replacing (and
  // stopping) a prefetch of other arguments that was not taken.
  void prefetch(int64_t step, bool conditions, int64_t rank = 0, int64_t world_size = 1,
                uint64_t stream = 0, int64_t bucket = -1) const;

  int64_t bucket_count() const { return static_cast<int64_t>(buckets_.size()); }

  // The draws that met a bad sample so far, by reason (the reader's message, the sample's name
  // replaced by "<sample>"); prefetched batches count as they are made.
  std::map<std::string, int64_t> skipped_samples() const;
  // The warnings not taken yet, oldest first: one per bad sample, when it is first met.
  std::vector<std::string> take_warnings();

 private:
  struct Request {
    int64_t step = 0;
    bool conditions = false;
    int64_t rank = 0, world_size = 1;
    uint64_t stream = 0;
    int64_t bucket = -1;
    bool operator==(const Request& other) const;
  };
  struct Bucket {
    int64_t width = 0, height = 0;
    std::vector<size_t> sources;  // indices into config_.datasets
  };
  struct BadSamples;  // what was met, shared by the threads that make items
  class Prefetcher;   // the background thread

  // A source's weight in this step: 0 for an unlabelled one unless A2P can label it.
  double source_weight(size_t source, bool conditions) const;
  double bucket_weight(const Bucket& bucket, bool conditions) const;
  const Bucket& step_bucket(const Request& request) const;
  // The sample of an item of `source`, drawn with the item's generator (again while bad).
  data::Sample draw_sample(size_t source, data::synth::Random& random) const;
  // Items are left out once `stop` is set (the batch is then incomplete, to be dropped).
  TrainingBatch make_batch(const Request& request, const std::atomic<bool>& stop) const;

  TrainConfig config_;
  std::vector<std::unique_ptr<data::Dataset>> datasets_;  // per source of config_.datasets
  std::vector<Bucket> buckets_;                           // in the order the sizes first appear
  augment::Teacher teacher_;  // A2P's, when enabled (one call at a time)
  std::unique_ptr<BadSamples> bad_samples_;
  std::unique_ptr<Prefetcher> prefetcher_;  // last: its thread stops before the rest goes
};

// A seed for a CPU generator derived from (seed, stream, index) by SplitMix64 mixing.
uint64_t derived_seed(uint64_t seed, uint64_t stream, uint64_t index);

}  // namespace omnipoint::train
