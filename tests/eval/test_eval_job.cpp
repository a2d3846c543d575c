// The eval job of the library: its options' checks (one line naming the flag), a run that
// writes the run's files with the predictor its options name, the saved point maps and the
// progress its observer is told.
#include <gtest/gtest.h>
#include <unistd.h>

#include <ATen/core/Tensor.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "eval/eval_test_data.h"
#include "omnipoint/eval/eval_job.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::eval {
namespace {
namespace fs = std::filesystem;

EvalJobOptions oracle_options(const fs::path& data, const fs::path& out) {
  EvalJobOptions options;
  options.baseline = "oracle";
  options.data = {data.string()};
  options.output_dir = out.string();
  return options;
}

// The message of the std::invalid_argument that Check() throws ("" when it passes).
std::string check_error(const EvalJobOptions& options) {
  try {
    options.Check();
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

TEST(EvalJobOptions, NameTheFlagOfEachProblem) {
  const EvalJobOptions good = oracle_options("data", "out");
  EXPECT_EQ(check_error(good), "");

  EvalJobOptions none = good;
  none.baseline.clear();
  EXPECT_EQ(check_error(none),
            "give exactly one of --model, --random-model, --predictions, --baseline");
  EvalJobOptions two = good;
  two.model = "model.safetensors";
  EXPECT_EQ(check_error(two), check_error(none));

  EvalJobOptions unknown = good;
  unknown.baseline = "mean";
  EXPECT_EQ(check_error(unknown), "--baseline mean: expected oracle, constant or median");
  EvalJobOptions stray_data = good;
  stray_data.baseline_data = {"train"};
  EXPECT_EQ(check_error(stray_data), "--baseline-data is for --baseline median only");
  EvalJobOptions median = good;
  median.baseline = "median";
  EXPECT_EQ(check_error(median),
            "--baseline median needs --baseline-data: the training samples of the cameras");
  median.baseline_data = {"train"};
  EXPECT_EQ(check_error(median), "");

  EvalJobOptions predictions = good;
  predictions.baseline.clear();
  predictions.predictions = "no_such_folder_of_predictions";
  EXPECT_EQ(check_error(predictions), "--predictions no_such_folder_of_predictions: not a folder");

  EvalJobOptions tokens = good;
  tokens.num_tokens = -1;
  EXPECT_EQ(check_error(tokens), "--num-tokens -1: expected >= 0");
  EvalJobOptions no_data = good;
  no_data.data.clear();
  EXPECT_EQ(check_error(no_data), "--data: no dataset folder given");
  EvalJobOptions suite = no_data;
  suite.suite = "suite.json";
  EXPECT_EQ(check_error(suite), "--suite needs --root: the folder holding the suite's sets");
  suite.suite_root = "data";
  EXPECT_EQ(check_error(suite), "");
  suite.format = "kitti360";
  EXPECT_EQ(check_error(suite), "--format is for --data; a suite names each set's format");
  EvalJobOptions both = good;
  both.suite = "suite.json";
  both.suite_root = "data";
  EXPECT_EQ(check_error(both), "give either --data (datasets) or --suite (a benchmark suite)");
  EvalJobOptions stray_root = good;
  stray_root.suite_root = "data";
  EXPECT_EQ(check_error(stray_root), "--root is for --suite only (datasets are given by --data)");
  EvalJobOptions split = good;
  split.split = "list.txt";
  EXPECT_EQ(check_error(split), "--split and --option need --format (the datasets' format)");
  split.format = "stanford2d3d";
  EXPECT_EQ(check_error(split), "");
  EvalJobOptions points = good;
  points.sparse_depth_points = 0;
  EXPECT_EQ(check_error(points), "--sparse-depth 0: expected a count >= 1");
  EvalJobOptions no_out = good;
  no_out.output_dir.clear();
  EXPECT_EQ(check_error(no_out), "--out: no output folder given");
}

// Counts the observer's calls and keeps the last.
class CountingObserver : public EvalJobObserver {
 public:
  void progress(int64_t done, int64_t total, double seconds) override {
    ++calls;
    last_done = done;
    last_total = total;
    EXPECT_GE(seconds, 0.0);
  }
  int calls = 0;
  int64_t last_done = -1, last_total = -1;
};

TEST(EvalJob, ScoresTheOracleWritesItsFilesAndSavesThePointsOfEveryMode) {
  const fs::path data = testing::make_tiny_dataset("eval_job", 1);
  const fs::path out =
      fs::temp_directory_path() / ("omnipoint_eval_job_out_" + std::to_string(::getpid()));
  fs::remove_all(out);
  EvalJobOptions options = oracle_options(data, out);
  options.intrinsics = true;
  options.sparse_depth = true;
  options.sparse_depth_points = 20;
  options.save_points = true;
  options.label = "truth";
  CountingObserver observer;
  const EvalJobResult result = EvalJob(options, &observer).Run();

  EXPECT_EQ(result.predictor, "truth");
  EXPECT_EQ(result.run.summary.samples_evaluated, 3);
  EXPECT_EQ(result.run.summary.modes, (std::vector<std::string>{"none", "+K", "+D", "+K+D"}));
  for (const auto& [split, modes] : result.run.summary.scores)
    for (const auto& [mode, scores] : modes)
      for (const auto& [entry, score] : scores.entries) {
        SCOPED_TRACE(split + " " + mode + " " + entry);
        EXPECT_NEAR(score.rel, 0.0, 1e-5);
      }
  EXPECT_EQ(observer.calls, 3);
  EXPECT_EQ(observer.last_done, 3);
  EXPECT_EQ(observer.last_total, 3);

  for (const char* file : {"samples.jsonl", "summary.json", "table.md"})
    EXPECT_TRUE(fs::is_regular_file(out / file)) << file;
  std::ifstream table_file(out / "table.md");
  const std::string table((std::istreambuf_iterator<char>(table_file)),
                          std::istreambuf_iterator<char>());
  EXPECT_EQ(table, result.table);
  EXPECT_NE(table.find("truth"), std::string::npos);

  // points/<dataset folder>/<id>/<mode>/: the scored map of the sample's size; +D's inputs.
  const fs::path sample = out / "points" / data.filename() / "sfov" / "0";
  for (const char* mode : {"none", "+K", "+D", "+K+D"}) {
    SCOPED_TRACE(mode);
    const at::Tensor points = io::read_npy((sample / mode / "points.npy").string());
    EXPECT_EQ(points.sizes(), (at::IntArrayRef{24, 32, 3}));
    const bool sparse = std::string(mode).find("+D") != std::string::npos;
    EXPECT_EQ(fs::exists(sample / mode / "sparse_distance.npy"), sparse);
  }
  fs::remove_all(data);
  fs::remove_all(out);
}

TEST(EvalJob, BadOptionsAreThrownBeforeAnythingIsWritten) {
  const fs::path out =
      fs::temp_directory_path() / ("omnipoint_eval_job_bad_" + std::to_string(::getpid()));
  EvalJobOptions options = oracle_options("no_such_dataset", out);
  options.baseline = "median";
  EXPECT_THROW(EvalJob(options).Run(), std::invalid_argument);
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace omnipoint::eval
