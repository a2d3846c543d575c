#pragma once
// The JSON configuration of `omnipoint train` (docs/TRAINING.md has a full example):
// {
//   "output_dir": "runs/small",            checkpoints, log.jsonl
//   "seed": 0, "threads": 1,                threads 1 + a seed = deterministic, resumable bit-exactly
//   "precision": "fp32",                    "bf16": the forward under autocast (model/precision.h)
//   "device": "cpu",                        "cuda": the model, its optimiser state and the
//                                           losses on GPU LOCAL_RANK (batches are made on the CPU)
//   "model": {OmniPointConfig JSON},        the network (init "scratch" and "dinov2"); with init
//                                           "omnipoint" only "conditioning" (ablations) and
//                                           "num_tokens_range" (the default token budget)
//   "init": {"from": "scratch" | "dinov2" | "moge2" | "omnipoint", "path": FILE,
//            "output": "ray_distance" | "xyz"  (moge2 only)},
//   "data": {"batch_size": 8, "image_size": [W, H], "num_tokens": [min, max],
//            "datasets": [{"weight": 1, "synth": {"scenes": ["indoor", ...], "cameras": [SPEC, ...]}},
//                         {"weight": 1, "folders": DIR,     DIR holds sample folders (data/sample.h)
//                          "image_size": [W, H],            this source's bucket (default: data's)
//                          "labels": true},                 false: unlabelled, enters only by A2P
//                         {"weight": 1, "format": "kitti-raw", "root": DIR,   a dataset in its
//                          "split": S, "options": {"camera": "image_02"}}],   native layout
//            "eval_datasets": [SOURCE, ...]},   held-out sources the in-run evaluation scores
//                                               (default: the training sources' own stream)
//   "conditions": {"probability": 0.9, "sparse_ratio": [0.0005, 0.001]},   from stage 2 on
//   "augment": {"p2a": false, "p2a_probability": 0.02,     from stage 2 on, see batch_source.h
//               "a2p": false, "a2p_probability": 1, "a2p_teacher": FILE, "a2p_teacher_tokens": 0,
//               "photometric": false, "flip": false},     every stage: colour jitter, blur, noise,
//                                                         JPEG (data/photometric.h); mirror images
//   "loss": {"point_loss": "decoupled" | "naive" | "disjoint", "align_trunc": 1,
//            "align_points": 0,         0: s* on every labelled pixel; see losses.h
//            "weights": {"point": 1, "ray": 1, "metric": 1, "normal": 1, "local": 1, "mask": 1,
//                        "gauge": 0},     gauge: not the paper's, see losses.h
//            "local": {"levels": [4, 16, 64], "patches_per_item": 16, "min_points": 32,
//                      "fit_points": 0}},      0: MoGe's exact fit on all points; see losses.h
//   "optimizer": {"weight_decay": 0.01, "betas": [0.9, 0.999], "eps": 1e-8, "grad_clip": 1.0},
//   "ema": {"decay": 0.999},
//   "stages": [{"stage": 1, "steps": 10000, "lr_backbone": 1e-4, "lr_heads": 1e-5,
//               "schedule": "step", "decay_every": 2000, "decay_factor": 0.5,   the paper's
//               "warmup_steps": 0},
//              {"stage": 2, ..., "schedule": "flat_cosine", "flat_fraction": 0.7,
//               "final_factor": 0.01}, {"stage": 3, ...}],
//   "checkpoint_every": 500, "log_every": 10, "eval_every": 0, "eval_batches": 4,
//   "eval_at_start": false,                 true: also evaluate before the first step
//   "max_nonfinite_steps": 10
// }
// Every key is optional except "stages" and the data sources; unknown keys are errors. Enums
// are parsed once, at load, and so are the synth cameras (spec strings or camera files, into
// camera::Camera). The table of keys, defaults and checks is in train_config.cpp (util/config.h
// reads and writes through it).
// Files: "extends": "base.json" takes a base file's keys (relative to the file; objects merge,
// arrays and values replace, null deletes), and `omnipoint train --set key.path=value`
// overrides any key (docs/TRAINING.md).
// Stages run in the order given. Stage 1: the conditions are off; stage 2: each condition is on
// per item with "probability"; stage 3: only the mask head trains (learning rate lr_heads), the
// objective is L_mask alone, the conditions as in stage 2.
#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/scene.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/model/precision.h"
#include "omnipoint/train/losses.h"

namespace omnipoint::train {

struct SynthSource {
  std::vector<data::synth::SceneKind> scenes{data::synth::SceneKind::kIndoor,
                                             data::synth::SceneKind::kOutdoor,
                                             data::synth::SceneKind::kObject};
  std::vector<camera::Camera> cameras;  // from specs or camera files; resized to the image size
};

struct DatasetSource {
  double weight = 1.0;
  bool synth = false;
  SynthSource synth_source;
  std::string folders;  // a directory of sample folders (the format "folders" at that root)
  // A dataset in its native layout, opened by data::open_dataset (data/dataset.h): its format
  // name ("kitti-raw", "rig-log", ...; "" for the synth and folders forms), root folder, split
  // (the format's split name or a split-list file; "": every item) and format options.
  std::string format;
  std::string root;
  std::string split;
  std::map<std::string, std::string> options;
  int64_t width = 0, height = 0;  // the image size of its items: its aspect-ratio bucket
  bool labelled = true;           // false: its items are pseudo-labelled by A2P (stage 2 on)
};

// The learning rate of a stage, as a factor of its lr_backbone / lr_heads:
//   kStep (the paper's): decay_factor^floor(step / decay_every) (decay_every 0: constant);
//   kFlatCosine: constant for flat_fraction of the stage, then half a cosine down to
//                final_factor at its last step.
// Either after a linear warm-up from 0 over warmup_steps.
enum class Schedule { kStep, kFlatCosine };

struct StageConfig {
  int stage = 1;  // 1, 2 or 3
  int64_t steps = 0;
  double lr_backbone = 1e-4;
  double lr_heads = 1e-5;
  Schedule schedule = Schedule::kStep;
  int64_t decay_every = 0;  // 0: constant
  double decay_factor = 0.5;
  double flat_fraction = 0.7;
  double final_factor = 0.01;
  int64_t warmup_steps = 0;

  // The factor at step `in_stage` (0-based) of this stage.
  double lr_factor(int64_t in_stage) const;
};

// Where the model, its optimiser state and the losses live ("cuda": GPU LOCAL_RANK).
enum class TrainDevice { kCpu, kCuda };
// The initial weights: fresh, a DINOv2 backbone, a MoGe-2 model or an OmniPoint model.
enum class InitSource { kScratch, kDinoV2, kMoGe2, kOmniPoint };

struct TrainConfig {
  std::string output_dir = "train_output";
  uint64_t seed = 0;
  int threads = 1;
  model::Precision precision = model::Precision::kFloat32;
  TrainDevice device = TrainDevice::kCpu;

  nlohmann::json model;  // OmniPointConfig JSON (null: none given)
  InitSource init_from = InitSource::kScratch;
  std::string init_path;
  model::OutputKind init_output = model::OutputKind::kRayDistance;  // init from MoGe-2 only

  int64_t batch_size = 2;
  int64_t width = 56, height = 56;
  std::array<int64_t, 2> num_tokens{16, 16};
  std::vector<DatasetSource> datasets;
  // Held-out sources for the in-run evaluation (labelled; their items as they are: no P2A, A2P,
  // photometric change or flip); empty: the training sources' separate evaluation stream.
  std::vector<DatasetSource> eval_datasets;

  double condition_probability = 0.9;
  std::array<double, 2> sparse_ratio{0.0005, 0.001};
  bool p2a = false, a2p = false;
  double p2a_probability = 0.02;   // share of perspective items rendered into a virtual wide camera
  double a2p_probability = 1.0;    // share of wide-FoV items whose labels are replaced by A2P's
  std::string a2p_teacher;         // checkpoint (OmniPoint or MoGe-2) pseudo-labelling A2P views
  int64_t a2p_teacher_tokens = 0;  // the teacher's token budget; 0: num_tokens' maximum
  bool photometric = false;        // data::photometric_augment on every item
  bool flip = false;               // mirror half of the items (image, labels and rays)

  LossConfig loss;
  double weight_decay = 0.01;
  std::array<double, 2> betas{0.9, 0.999};
  double eps = 1e-8;
  double grad_clip = 1.0;  // 0: no clipping
  double ema_decay = 0.999;

  std::vector<StageConfig> stages;
  int64_t checkpoint_every = 500;
  int64_t log_every = 10;
  int64_t eval_every = 0;
  int64_t eval_batches = 4;
  bool eval_at_start = false;  // also evaluate the starting weights (a fresh start's step 0)
  int64_t max_nonfinite_steps = 10;

  int64_t total_steps() const;
  // std::invalid_argument, one line naming the key path and what was expected
  // ("training config: stages[1].steps: must be at least 1").
  static TrainConfig from_json(const nlohmann::json& json);
  // The config file's text (no "extends": there is no file to resolve it against); errors (not
  // JSON, or from_json's) name `source`.
  static TrainConfig from_text(const std::string& text, const std::string& source);
  // The file `path` with its "extends" chain merged and the `overrides` ("key.path=value",
  // util/config.h) applied, then read as from_json; errors name the file or the override.
  static TrainConfig load(const std::string& path, const std::vector<std::string>& overrides = {});
  // Every key, resolved (the cameras as specs): what a run records. from_json reads it back
  // to an equal config.
  nlohmann::json to_json() const;
};

}  // namespace omnipoint::train
