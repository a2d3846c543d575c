#pragma once
// Rig consistency scored against ground truth (`omnipoint eval --rig RIG.json --frames FRAMES`,
// docs/EVALUATION.md "Rigs"): predict --rig's job (rig_predict_job.h) runs over frames that have
// truth — as `omnipoint synth --rig` writes them, TRUTH/<frame>/<camera>/distance.npy — under
// up to three rules, each into OUT/<rule>/:
//   lidar        the sweeps (the frames' lidar.<ext>), the overlap rule for the cameras without
//                samples; only when some frame has a sweep and RigEvalOptions::lidar
//   overlap      no sweep: the cameras reconciled where their views overlap
//   independent  no sweep, no overlap rule: the cameras at the median of their network scales
// Per frame and camera: the camera's scale (rig.json's "scale": the factor that took its network
// distances to metres) against the true scale (the factor that takes the same network distances
// to the truth: geometry::fit_scale_to_sparse_depth over the camera's valid pixels), the error
// scale / true scale - 1, and the same for the scale its outputs carry ("applied_scale"). Per
// frame: the spread of the cameras' scale errors (the largest scale / true scale over the
// smallest, minus 1: 0 when the cameras agree with each other, whatever their common error) and
// the overlap residual (rig.json's). Per rule: the means over frames (mean |error| per camera).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/predict/rig_predict_job.h"

namespace omnipoint::predict {

struct RigEvalOptions {
  // The rig, the frames, the model (or a predictor), the sizes; job.output_dir is OUT (the rules'
  // predictions go below it), job.output_files and job.lidar / job.overlap are set per rule.
  RigPredictJobOptions job;
  std::string truth_dir;  // TRUTH/<frame>/<camera>/distance.npy; "": FRAMES/../truth
  bool lidar = true;      // score the lidar rule too when frames have sweeps (--no-lidar: not)

  // std::invalid_argument with one line for an option that is invalid.
  void Check() const;
};

struct RigEvalCamera {
  std::string name;
  std::string scale_source;  // rig.json's
  double scale = 0;          // rig.json's
  double applied_scale = 0;  // rig.json's
  double true_scale = 0;     // the network distances' factor to the truth
  double error = 0;          // scale / true scale - 1
  double applied_error = 0;  // applied scale / true scale - 1
};

struct RigEvalFrame {
  std::string name;
  std::vector<RigEvalCamera> cameras;
  double spread = 0;                       // max / min of scale / true scale, minus 1
  double applied_spread = 0;               // the same for the applied scales
  std::optional<double> overlap_residual;  // rig.json's
};

struct RigEvalRule {
  std::string name;  // "lidar", "overlap", "independent"
  std::vector<RigEvalFrame> frames;
  // Means over the frames.
  std::vector<std::string> camera_names;  // the rig's cameras, in order
  std::vector<double> mean_abs_error;     // per camera, over the frames that have it
  double mean_spread = 0, mean_applied_spread = 0;
  std::optional<double> mean_overlap_residual;  // over the frames that have one
};

struct RigEvalResult {
  std::vector<RigEvalRule> rules;
  std::string report_path;  // OUT/rig_eval.json
  std::string table;        // markdown, one row per rule
};

// Runs the rules and scores them; writes OUT/rig_eval.json (atomically). Errors of the job (a
// bad rig, no frames, no model) and a frame without a truth folder are std::invalid_argument,
// one line, before any prediction; a frame the job could not predict or a camera without its
// truth file is a std::runtime_error naming the rule and the frame.
RigEvalResult evaluate_rig(const RigEvalOptions& options);

}  // namespace omnipoint::predict
