#pragma once
// Benchmark suites (`omnipoint eval --suite FILE --root DATA_ROOT`): named evaluation sets, each
// in a dataset format under a common data root, grouped by camera type, and the table of a
// predictor's scores per group (the paper's Table 1 layout) and per set.
//
// The suite file (JSON; benchmarks/paper_suite.json is the paper's):
//   {
//     "name": "paper",
//     "columns": {"depth": "depth_scale_invariant", "points": "points_scale_invariant",
//                 "metric": "depth_metric"},
//     "sets": [
//       {"name": "NYUv2", "group": "S.FoV", "format": "moge", "root": "NYUv2", "metric": true,
//        "modes": ["none", "+K", "+D", "+K+D"]},
//       {"name": "KITTI-360", "group": "L.FoV", "format": "kitti360", "root": "KITTI-360",
//        "split": "splits/kitti360_val_fisheye_dac.txt", "options": {"gt_rule": "dac"},
//        "modes": ["none"]},
//       ...
//     ]
//   }
//   columns   the protocol entries (metrics.h) of the table's depth, points and metric columns;
//   name      unique; how records, tables and --save-points name the set;
//   group     "S.FoV", "L.FoV" or "360°": the table's column group;
//   format    a registered dataset format (data/dataset.h);
//   root      the set's folder, relative to the data root;
//   split     optional: one of the format's named splits, or a split list file relative to the
//             suite file's folder;
//   options   optional: the format's options (strings);
//   metric    optional, default true: the depth is in metres (formats without their own flag:
//             moge);
//   modes     the condition modes ("none", "+K", "+D", "+K+D") the set is scored in when the
//             run enables them; "none" must be among them;
//   group_mean optional, default true: false for a set reported on its own but left out of its
//             group's mean (a second list of a dataset already in the group).
// A group's score is the unweighted mean over its sets of each set's mean over its samples
// (MoGe's mean over benchmarks): a large set does not outweigh a small one.
#include <map>
#include <string>
#include <vector>

#include "omnipoint/eval/runner.h"

namespace omnipoint::eval {

struct SuiteSet {
  std::string name;
  std::string group;   // split_name() of a Split
  std::string format;  // a registered dataset format
  std::string root;    // relative to the data root
  std::string split;   // a named split, or a list file (resolved against the suite's folder)
  std::map<std::string, std::string> options;
  bool metric = true;
  std::vector<std::string> modes;  // Mode::name()s, "none" among them
  bool group_mean = true;
};

// The protocol entries (kMetricEntries) the table shows.
struct SuiteColumns {
  std::string depth = "depth_scale_invariant";
  std::string points = "points_scale_invariant";
  std::string metric = "depth_metric";
};

struct Suite {
  std::string name;
  SuiteColumns columns;
  std::vector<SuiteSet> sets;
};

// Parses a suite file's text; `source` names it in errors, relative split lists are resolved
// against `folder`. Anything malformed -> std::invalid_argument with one line naming the source
// and the key, e.g. "suite.json: sets[2].group: expected \"S.FoV\", \"L.FoV\" or \"360°\"".
Suite parse_suite(const std::string& text, const std::string& source, const std::string& folder);
// Reads and parses a suite file (errors as parse_suite; an unreadable file names it).
Suite read_suite(const std::string& path);

// Scores of one set of a suite.
struct SuiteSetScores {
  SuiteSet set;
  Summary summary;  // of the set's own run
};

struct SuiteResult {
  Suite suite;
  std::string model;                 // the predictor's label
  std::string root;                  // the data root
  std::vector<SuiteSetScores> sets;  // those found, in the suite's order
  std::vector<SuiteSet> missing;     // those whose root is not under the data root
  std::vector<std::string> records;  // every set's samples.jsonl lines
  std::vector<std::string> modes;    // the modes that ran on some set, in Mode order
};

struct SuiteRunOptions {
  std::string root;                 // the data root
  std::vector<Mode> modes{Mode{}};  // the modes enabled (each set runs those it lists)
  RunOptions run;  // sparse depth, seed, callbacks (progress: over all sets' samples)
};

// Opens every set whose root is under the data root (a set that is there but does not open ->
// std::runtime_error naming the set, before anything is scored; none there ->
// std::runtime_error), then scores each.
SuiteResult run_suite(const Predictor& predictor, const Suite& suite,
                      const SuiteRunOptions& options);

// The mean of a set's scores of one entry over its samples, whatever their camera split
// (each split's average weighted by its count); NaN when the set has none.
AveragedScore set_score(const Summary& summary, const std::string& mode, const std::string& entry);
// A group's score of one entry: the mean over the group's sets (group_mean) that have it.
AveragedScore group_score(const SuiteResult& result, const std::string& group,
                          const std::string& mode, const std::string& entry);

// The tables: per group and mode depth / points Rel and δ1 (the paper's Table 1), per set and
// mode those and the metric δ1, and the sets not found.
std::string suite_markdown(const SuiteResult& result);
std::string suite_json(const SuiteResult& result);
// samples.jsonl, table.md (suite_markdown) and table.json (suite_json) in `folder` (created),
// each written atomically. Returns table.md's text.
std::string write_suite_files(const std::string& folder, const SuiteResult& result);

}  // namespace omnipoint::eval
