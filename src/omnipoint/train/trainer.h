#pragma once
// The training loop: stages, per-group learning rates with step decay, AdamW, gradient
// clipping, EMA, condition sampling, non-finite step skipping, and the complete state for an
// exact resume.
//
// Parameter groups (paper, "Training Strategy"): "backbone" = the DINOv2 encoder
// (encoder.backbone.*), "heads" = everything else (projections, neck, heads, conditioning).
// Each stage builds a fresh AdamW; lr = lr_group · decay_factor^floor(step_in_stage / decay_every).
// Stage 3 trains the mask head alone (requires_grad off elsewhere) with lr_heads on L_mask.
//
// Determinism: with config.threads = 1, everything a step does is a function of the
// parameters, the optimiser state and the step number (batches: batch_source.h; local-loss
// anchors: a generator keyed by the step), so restore(checkpoint()) continues bit-exactly.
// Each step starts making the next step's batch in the background (BatchSource::prefetch)
// before it computes its own.
#include <ATen/core/Tensor.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/train/batch_source.h"
#include "omnipoint/train/train_config.h"

namespace torch::optim {
class AdamW;
}

namespace omnipoint::train {

struct StepRecord {
  int64_t step = 0;  // steps completed after this one
  int stage = 1;
  bool skipped = false;  // non-finite loss or gradients: no update
  double loss = 0;
  std::map<std::string, double> terms;  // batch means of the unweighted terms
  double grad_norm = 0;
  double lr_backbone = 0, lr_heads = 0;
  int64_t images = 0;
  int64_t num_tokens = 0;
  int64_t width = 0, height = 0;  // the step's image size (its aspect bucket)
  // Wall seconds of the step's phases: "data" (what is left of making the batch, which was
  // prefetched during the previous step), "forward", "loss" (and "loss.<term>"), "backward"
  // (with the gradient all-reduce), "optimizer" (with the EMA).
  std::map<std::string, double> seconds;
};

// Everything an exact resume needs. Tensors are CPU copies.
// NOLINTNEXTLINE(bugprone-exception-escape): the implicit moves are those of std::map and json.
struct TrainState {
  std::map<std::string, at::Tensor> model;  // state_dict names
  std::map<std::string, at::Tensor> ema;    // the same names
  std::map<std::string, at::Tensor>
      optimizer;                          // "<param>.exp_avg", "<param>.exp_avg_sq", "<param>.step"
  std::map<std::string, at::Tensor> rng;  // "torch_cpu": the default CPU generator's state
  nlohmann::json progress;                // {"step", "consecutive_nonfinite", "optimizer_stage"}
  std::map<std::string, std::string> model_metadata;  // the model file's (read_checkpoint)
};

// Data-parallel ranks (distributed.h); the default is one process.
class DistributedContext;

class Trainer {
 public:
  // `distributed` (kept by reference, must outlive the trainer) selects this process's shard
  // of each global batch and averages the gradients; rank 0's weights are copied to every
  // rank here. Computes on config.threads (util::set_threads).
  Trainer(TrainConfig config, model::OmniPointModel model, const DistributedContext& distributed);
  Trainer(TrainConfig config, model::OmniPointModel model);
  ~Trainer();

  bool done() const { return step_ >= config_.total_steps(); }
  int64_t step() const { return step_; }
  const TrainConfig& config() const { return config_; }
  model::OmniPointModel& model() { return model_; }
  // Where the batches come from (its warnings and skipped-sample counts).
  BatchSource& batch_source() { return source_; }
  // The EMA of the parameters (and the buffers as they are), by state_dict name.
  const std::map<std::string, at::Tensor>& ema() const { return ema_; }

  // One optimisation step. Throws std::runtime_error after max_nonfinite_steps skipped steps
  // in a row.
  StepRecord train_step();

  // The EMA weights' mean losses over config.eval_batches fixed batches (a separate data
  // stream of the training sources, or of the held-out data.eval_datasets where the config
  // names any; batch b from aspect bucket b modulo their number), no update, plus the
  // benchmark's scores on them: points_rel/points_delta1 (scale-invariant points) and
  // metric_rel/metric_delta1 (metric points, metric items only), as fractions.
  std::map<std::string, double> evaluate();

  TrainState state() const;
  // std::invalid_argument when the state does not fit this model and config.
  void restore(const TrainState& state);

 private:
  int stage_index(int64_t step) const;
  int64_t stage_start(int index) const;
  void configure_stage(int index);
  model::OmniPointOutput forward(const TrainingBatch& batch, bool conditions);
  LossConfig stage_loss(int index) const;

  TrainConfig config_;
  at::Device device_;  // the config's device: the model, its EMA and optimiser state, the losses
  model::OmniPointModel model_;
  const DistributedContext& distributed_;
  int64_t rank_, world_size_;
  BatchSource source_;
  std::unique_ptr<BatchSource> eval_source_;  // data.eval_datasets' (null: none)
  std::map<std::string, at::Tensor> ema_;
  std::unique_ptr<torch::optim::AdamW> optimizer_;
  std::vector<std::vector<std::string>> group_names_;  // parameter names per optimiser group
  std::vector<std::string> group_kinds_;               // "backbone" | "heads"
  int current_stage_ = -1;
  int64_t step_ = 0;
  int64_t consecutive_nonfinite_ = 0;
};

// The network a config asks for: built from "model" (scratch), then initialised from a DINOv2
// or MoGe-2 checkpoint, or loaded from an OmniPoint checkpoint ("init"). Reads init.path.
// Seeds the default generator with config.seed first, so fresh weights are reproducible.
model::OmniPointModel build_model(const TrainConfig& config);

}  // namespace omnipoint::train
