#pragma once
// A training session: the run of a TrainConfig from its first (or a checkpoint's) step to the
// end of its stages, with everything a run writes — what `omnipoint train` does, as a library
// pipeline (options with a Check(), a Run(), progress and warnings through an observer).
//
// The config's output_dir receives, from rank 0 only (the other ranks of a data-parallel job
// train and evaluate alike but write nothing):
//   log.jsonl       one JSON line per step {"step", "stage", "loss", "terms", "grad_norm",
//                   "skipped", "lr_backbone", "lr_heads", "num_tokens", "image_size",
//                   "seconds", "images_per_s"}, and one per evaluation {"step", "eval"}
//                   (step 0: the starting weights, with eval_at_start)
//   checkpoints/    every checkpoint_every steps and when the session ends (checkpoint.h)
//   curves.png      with each checkpoint and at the end (curves.h; builds with image I/O)
//   model.safetensors, model_ema.safetensors
//                   once the last stage is done: the weights and their EMA, as predict loads
// A resumed session continues exactly where its checkpoint left off (trainer.h): the log keeps
// the records up to the checkpoint's step, and the steps redone write theirs again, so an
// interrupted and resumed run leaves what the uninterrupted one leaves.
#include <cstdint>
#include <string>

#include "omnipoint/train/train_config.h"
#include "omnipoint/train/trainer.h"

namespace omnipoint::train {

struct TrainingSessionOptions {
  // The run: network, data, stages, output_dir, threads and cadences.
  TrainConfig config;
  // A checkpoint to continue from: a run's output_dir, its checkpoints/ folder or one step
  // folder ("": a fresh start).
  std::string resume;
  // > 0: end (with a checkpoint) once this many steps are done in total, as an interruption
  // would; 0: run to the end of the stages.
  int64_t stop_after = 0;

  // std::invalid_argument naming the field when no session can run these options.
  void Check() const;
};

// A step's progress.
struct TrainingProgress {
  StepRecord record;             // the step (trainer.h)
  int64_t total_steps = 0;       // of the config's stages
  double images_per_second = 0;  // over the steps of this session (all ranks' images)
  double seconds_left = 0;       // to the end of the stages, at this session's pace
};

// What a session reports; each call comes from the thread that runs the session, and the
// default ignores it.
class TrainingObserver {
 public:
  virtual ~TrainingObserver();
  // Every log_every steps and at the session's last step (rank 0).
  virtual void progress(const TrainingProgress& progress);
  // Something that does not stop the run: a step skipped for a non-finite loss or gradients
  // (rank 0); a bad sample skipped, and at the end how often one was met (every rank: its own).
  virtual void warning(const std::string& text);
  // The last stage is done and its weights are at `model_path` (rank 0).
  virtual void finished(const std::string& model_path);
};

class TrainingSession {
 public:
  // `observer` (may be null) must outlive Run().
  explicit TrainingSession(TrainingSessionOptions options, TrainingObserver* observer = nullptr);

  // Runs the session on the config's threads (util::set_threads), as one process or as a rank
  // of a data-parallel job (distributed.h: RANK, WORLD_SIZE, ... in the environment).
  // std::invalid_argument for options or a checkpoint that do not fit; std::runtime_error for
  // unreadable data or files, a failed collective, too many non-finite steps in a row.
  void Run();

  const TrainingSessionOptions& options() const { return options_; }

 private:
  struct Outputs;  // the files rank 0 writes
  // The steps to the end (or stop_after): log, progress, checkpoints, evaluations.
  void train(Trainer& trainer, const Outputs& outputs);
  // The bad-sample warnings of the steps so far, to the observer.
  void report_data_warnings(Trainer& trainer);

  TrainingSessionOptions options_;
  TrainingObserver* observer_;
};

// OUTPUT_DIR/curves.png drawn anew from OUTPUT_DIR/log.jsonl (a run in progress or done).
// std::runtime_error when there is no log or this build has no image file I/O.
void redraw_training_curves(const std::string& output_dir);

}  // namespace omnipoint::train
