#pragma once
// The benchmark runner (`omnipoint eval`): scores a predictor over datasets with MoGe's
// protocol (metrics.h), per camera split and per condition mode, and summarises the scores
// like the paper's tables. docs/EVALUATION.md states the protocol choices.
//
// Every predictor answers with rays, distances and a metric scale, so models of any kind and
// external point maps are scored identically:
//   points = metric_scale · distance · ray   (metric_scale 1 and not metric when it has none)
// A network's point map is the one `omnipoint predict` ships (infer::point_map: zero where its
// mask is false), so a masked pixel scores as predict writes it.
//   "depth" = points.z on the small-FoV (pinhole) split, where it is MoGe's planar depth;
//             the radial distance ‖points‖ on the fisheye and 360° splits, where planar depth
//             is ≤ 0 for rays at or beyond 90° from the axis (same definition for the GT).
// Splits follow the sample's camera model: EQUIRECTANGULAR -> 360°; fisheye, unified and FOV
// models -> L.FoV; the pinhole and OpenCV-style models -> S.FoV.
// Modes: "none", "+K" (the GT camera's ray map given), "+D" (N GT distances sampled uniformly
// from the valid pixels, seeded by the sample id: the same points for every model and run),
// "+K+D".
#include <ATen/core/Tensor.h>

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/eval/metrics.h"

namespace omnipoint::eval {

enum class Split { kSmallFov, kLargeFov, kPanorama };
extern const std::array<Split, 3> kSplits;
std::string split_name(Split split);  // "S.FoV", "L.FoV", "360°"
Split camera_split(const camera::Camera& camera);

struct Mode {
  bool intrinsics = false;
  bool sparse_depth = false;
  std::string name() const;  // "none", "+K", "+D", "+K+D"
};
// "none" always, then +K, +D and +K+D as enabled.
std::vector<Mode> evaluation_modes(bool intrinsics, bool sparse_depth);

// One sample as the predictor sees it.
struct EvalSample {
  std::string dataset;  // the dataset root as given
  std::string id;       // relative to it
  Split split;
  data::Sample sample;
};

// The conditions of one mode; undefined tensors are absent.
struct Conditions {
  at::Tensor rays;          // (H, W, 3) the GT camera's unit rays (zero where invalid)
  at::Tensor sparse_depth;  // (H, W) GT distances at the sampled pixels, 0 elsewhere
};

struct GeometryPrediction {
  at::Tensor rays;      // (H, W, 3) unit rays
  at::Tensor distance;  // (H, W) along them
  double metric_scale = 1.0;
  bool is_metric = false;  // whether metric_scale makes the points metres
  // (H, W, 3) the point map to score, when the predictor ships one (a network: predict's,
  // infer::point_map, zero outside its mask); else metric_scale · distance · ray.
  at::Tensor points{};
};

// Thrown by a predictor that has no prediction for a sample (e.g. a missing external file):
// the sample is skipped with the reason "missing prediction".
struct MissingPrediction : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Predictor {
  std::string name;  // the table's row label
  bool accepts_intrinsics = false;
  bool accepts_sparse_depth = false;
  std::function<GeometryPrediction(const EvalSample&, const Conditions&)> predict;
};

struct RunOptions {
  std::vector<Mode> modes{Mode{}};
  int64_t sparse_depth_points = 1000;
  uint64_t seed = 0;        // mixed into every sample's sparse-depth seed
  bool moge_metric = true;  // MoGe benchmark depth is in metres
  // Called after each sample: (samples done, total, seconds elapsed).
  std::function<void(int64_t, int64_t, double)> progress;
  // Called with each sample × mode's conditions and prediction once scored (`omnipoint eval
  // --save-points`).
  std::function<void(const EvalSample&, const Mode&, const Conditions&, const GeometryPrediction&)>
      scored;
};

// The scores of one split and mode, averaged over its samples (NaN entries excluded, counted).
struct SplitScores {
  int64_t samples = 0;
  std::map<std::string, AveragedScore> entries;
};

struct Summary {
  std::string model;
  std::vector<std::string> datasets;
  std::vector<std::string> modes;                // the modes that ran, in order
  std::vector<std::string> modes_not_supported;  // asked for but the predictor takes no such input
  int64_t sparse_depth_points = 0;
  int64_t samples_total = 0;
  int64_t samples_evaluated = 0;
  std::map<std::string, int64_t> skipped;  // reason -> samples
  // split name -> mode name -> scores
  std::map<std::string, std::map<std::string, SplitScores>> scores;
};

struct RunResult {
  std::vector<std::string> records;  // one JSON object per line: a sample × mode, or a skip
  Summary summary;
};

// Where an evaluation dataset is: a folder found by its files (sample folders, MoGe benchmarks:
// data/dataset_index.h) or a registered format's root (data/dataset.h: open_dataset).
struct EvalSource {
  std::string name;    // how records and summaries name the dataset (the root as given)
  std::string format;  // a registered format ("kitti360", "moge", ...); "": found by its files
  data::DatasetLocation location;  // root, split, options; `metric` for MoGe benchmarks
};

// A dataset's samples, listed (each read when scored).
struct EvalItem {
  std::string id;  // relative to the dataset's root ("/"-separated)
  std::function<data::Sample()> read;
};
struct EvalDataset {
  std::string name;
  std::vector<EvalItem> items;
};

// Lists a source's samples. A root that is missing or holds no sample, an unknown format or
// option, a split list naming missing files -> std::runtime_error / std::invalid_argument
// naming it.
EvalDataset open_eval_dataset(const EvalSource& source);

// Runs `predictor` on every sample of the datasets in every mode. A sample that cannot be read
// or predicted is skipped, with its reason counted and recorded.
RunResult score_datasets(const Predictor& predictor, const std::vector<EvalDataset>& datasets,
                         const RunOptions& options);
// score_datasets on dataset folders found by their files (open_eval_dataset of each, MoGe
// benchmarks metric as options.moge_metric says). A dataset that is missing or empty ->
// std::runtime_error.
RunResult run_benchmark(const Predictor& predictor, const std::vector<std::string>& datasets,
                        const RunOptions& options);

// The point map a prediction is scored by (GeometryPrediction::points).
at::Tensor scored_points(const GeometryPrediction& prediction);

// The scores of one sample: ground truth from the sample, prediction from `prediction`.
Metrics score_sample(const data::Sample& sample, Split split, const GeometryPrediction& prediction);

// The conditions of `mode` for a sample (sparse depth drawn with `seed`).
Conditions make_conditions(const data::Sample& sample, const Mode& mode,
                           int64_t sparse_depth_points, uint64_t seed);
// The sparse-depth seed of a sample: a hash of its id mixed with the run seed.
uint64_t sample_seed(const std::string& id, uint64_t seed);

// The summary as JSON text (NaN as null).
std::string summary_json(const Summary& summary);

// A table cell: `value` (a fraction) in percent, Rel with 2 decimals, δ1 with 1; "–" when not
// finite.
std::string percent_cell(double value, bool rel);

// The paper-style table: a row per summary and mode; per split (in kSplits order, those
// present in any summary) depth Rel / δ1 (depth_scale_invariant), points Rel / δ1
// (points_scale_invariant) and metric δ1 (points_metric), in percent.
std::string markdown_table(const std::vector<Summary>& summaries);

// A run's files in `folder` (created), each written atomically: samples.jsonl (the records, one
// a line), summary.json (summary_json) and table.md (markdown_table of the run's summary).
// Returns the table.
std::string write_run_files(const std::string& folder, const RunResult& result);

}  // namespace omnipoint::eval
