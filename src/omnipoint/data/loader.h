#pragma once
// The training data loader: mixes several datasets with weights, fits every sample to a
// per-batch image size of about `num_tokens` ViT patches (resize + random crop, cameras
// updated exactly), applies photometric augmentation, and prefetches batches on worker
// threads. Batch k is a pure function of (options, k): the stream is reproducible whatever
// the worker count or timing.
//
// Sources:
//   "folder": a folder of sample folders in the format of sample.h (or one sample folder)
//   "moge":   a MoGe evaluation benchmark root (moge_format.h)
//   "synth":  samples rendered on the fly by the synthetic scene engine
// Bad samples (missing/corrupt files, size mismatches, NaN/negative depth, unknown
// camera) are skipped: logged once to stderr and counted by reason. A source without any
// usable sample is an error (std::runtime_error from the constructor or next()).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/photometric.h"

namespace omnipoint::data {

struct DataSource {
  std::string kind;     // "folder" | "moge" | "synth"
  std::string path;     // folder / moge root
  double weight = 1.0;  // relative sampling weight
  bool metric = true;   // moge only (folders say it in meta.json; synth is metric)
  std::vector<std::string> scenes{"indoor", "outdoor", "object"};  // synth
  std::vector<std::string> cameras;  // synth: camera specs, drawn uniformly
};

struct LoaderOptions {
  std::vector<DataSource> sources;
  int64_t batch_size = 4;
  int64_t num_tokens = 600;                   // image area ~ num_tokens * patch_size^2
  int64_t patch_size = 14;                    // height and width are multiples of it
  double min_aspect = 0.5, max_aspect = 2.0;  // width / height, log-uniform per batch
  bool augment = true;
  PhotometricOptions photometric;
  int workers = 2;
  int prefetch = 4;  // batches prepared ahead
  std::uint64_t seed = 0;
};

struct Batch {
  at::Tensor image;     // (B, 3, H, W) float32 RGB in [0, 1]
  at::Tensor rays;      // (B, H, W, 3) float32 unit rays (zero where invalid)
  at::Tensor distance;  // (B, H, W) float32, 0 where mask is false
  at::Tensor mask;      // (B, H, W) bool
  at::Tensor metric;    // (B) bool
  std::vector<camera::Camera> cameras;
  std::vector<std::string> sources;  // where each sample came from
};

class Loader {
 public:
  explicit Loader(LoaderOptions options);
  ~Loader();
  Loader(const Loader&) = delete;
  Loader& operator=(const Loader&) = delete;

  // The next batch in order (blocks until a worker has it).
  Batch next();
  // Skipped samples so far: reason -> count.
  std::map<std::string, int64_t> skipped() const;

  struct State;

 private:
  std::shared_ptr<State> state_;
};

// The per-batch image size for a token budget and aspect ratio (multiples of patch_size).
std::pair<int64_t, int64_t> batch_image_size(int64_t num_tokens, int64_t patch_size, double aspect);

}  // namespace omnipoint::data
