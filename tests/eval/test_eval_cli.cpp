// End to end: a tiny synthetic benchmark rendered by `omnipoint synth --benchmark`, scored by
// `omnipoint eval` with a tiny random-weight OmniPoint model, with external point maps and
// with a baseline; bad inputs give one clear line and a non-zero exit.
#include <gtest/gtest.h>

#include <ATen/ATen.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/data/dataset_index.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/model/state_dict.h"
#include "support/cli_run.h"
#include "support/tiny_omnipoint.h"

namespace {
namespace fs = std::filesystem;

using omnipoint::test::CliRun;
using omnipoint::test::slurp;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream stream(text);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  return lines;
}

const fs::path& work_dir() {
  static const fs::path dir = omnipoint::test::fresh_process_dir("omnipoint_eval_cli");
  return dir;
}

CliRun run_cli(const std::string& args) {
  return omnipoint::test::run_omnipoint(args, work_dir());
}

void expect_one_error_line(const CliRun& run, const std::string& needle) {
  EXPECT_NE(run.status, 0);
  const auto lines = lines_of(run.err);
  ASSERT_EQ(lines.size(), 1u) << run.err;
  EXPECT_EQ(lines[0].rfind("omnipoint: error: ", 0), 0u) << run.err;
  EXPECT_NE(lines[0].find(needle), std::string::npos) << run.err;
}

// Two samples per split at tiny resolutions, no shadows or AO.
const char* kTinyBenchmark = R"({
  "name": "tiny", "version": 1,
  "sets": {"main": 10, "final": 20},
  "render": {"shadows": false, "ambient_occlusion": false},
  "splits": [
    {"name": "S.FoV", "count": 2, "scenes": ["indoor", "outdoor"],
     "cameras": ["PINHOLE 32 24 24 24 16 12", "OPENCV 32 24 24 24 16 12 -0.05 0.01 0 0"]},
    {"name": "L.FoV", "count": 2, "scenes": ["outdoor"], "cameras": ["OPENCV_FISHEYE 32 32 9.6 9.6 16 16 0 0 0 0"]},
    {"name": "360", "count": 2, "scenes": ["indoor"], "cameras": ["EQUIRECTANGULAR 32 16"]}
  ]
})";

class EvalCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::ofstream(work_dir() / "tiny.json") << kTinyBenchmark;
    const CliRun synth = run_cli("synth --benchmark " + (work_dir() / "tiny.json").string() +
                                 " --out " + (work_dir() / "data").string());
    ASSERT_EQ(synth.status, 0) << synth.err;
    at::manual_seed(3);
    const auto config = omnipoint::model::OmniPointConfig::from_json_text(
        omnipoint::test::tiny_omnipoint_config_json());
    omnipoint::model::OmniPointModel model(config);
    omnipoint::io::write_safetensors((work_dir() / "tiny.safetensors").string(),
                                     omnipoint::model::state_dict(*model),
                                     omnipoint::model::omnipoint_metadata(config));
  }
  static void TearDownTestSuite() { fs::remove_all(work_dir()); }
  static std::string data() { return (work_dir() / "data").string(); }
};

TEST_F(EvalCli, SynthBenchmarkWritesEverySplitAndSample) {
  for (const char* split : {"S.FoV", "L.FoV", "360"})
    for (const char* index : {"0000", "0001"})
      EXPECT_TRUE(fs::exists(work_dir() / "data" / split / index / "distance.npy"))
          << split << index;
  EXPECT_FALSE(fs::exists(work_dir() / "data" / "S.FoV" / "0002"));
  // The same definition renders identical files.
  const CliRun again = run_cli("synth --benchmark " + (work_dir() / "tiny.json").string() +
                               " --per-split 1 --out " + (work_dir() / "again").string());
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_EQ(slurp(work_dir() / "again" / "L.FoV" / "0000" / "distance.npy"),
            slurp(work_dir() / "data" / "L.FoV" / "0000" / "distance.npy"));
  EXPECT_FALSE(fs::exists(work_dir() / "again" / "L.FoV" / "0001"));
}

// A set rendered by two shards equals one render; a rerun keeps what exists and finishes what
// an interrupted run left (a staging folder, io::StagedFolder); --core-files writes only what
// training reads.
TEST_F(EvalCli, SynthDefinitionShardsResumeAndCoreFiles) {
  const std::string definition = (work_dir() / "tiny.json").string();
  const fs::path sharded = work_dir() / "sharded";
  for (const char* shard : {"0/2", "1/2"}) {
    const CliRun run = run_cli("synth --definition " + definition + " --shard " + shard +
                               " --core-files --out " + sharded.string());
    ASSERT_EQ(run.status, 0) << run.err;
    EXPECT_NE(run.err.find("3 samples rendered"), std::string::npos) << run.err;
  }
  for (const char* split : {"S.FoV", "L.FoV", "360"})
    for (const char* index : {"0000", "0001"}) {
      const fs::path folder = sharded / split / index;
      EXPECT_EQ(slurp(folder / "distance.npy"),
                slurp(work_dir() / "data" / split / index / "distance.npy"))
          << folder;
      EXPECT_TRUE(fs::exists(folder / "image.png") && fs::exists(folder / "mask.png") &&
                  fs::exists(folder / "meta.json"));
      EXPECT_FALSE(fs::exists(folder / "rays.npy") || fs::exists(folder / "normals.npy") ||
                   fs::exists(folder / "depth.npy"))
          << folder;
    }
  // An interrupted run: one sample half written (its staging folder, no longer locked by the
  // process that died), another missing.
  fs::remove_all(sharded / "360" / "0001");
  const fs::path half_written = sharded / "360" / ".0001.partial-Xy12z9";
  fs::create_directories(half_written);
  std::ofstream(half_written / "image.png") << "half";
  const CliRun resumed =
      run_cli("synth --definition " + definition + " --core-files --out " + sharded.string());
  ASSERT_EQ(resumed.status, 0) << resumed.err;
  EXPECT_NE(resumed.err.find("1 samples rendered"), std::string::npos) << resumed.err;
  EXPECT_NE(resumed.err.find("5 already there"), std::string::npos) << resumed.err;
  EXPECT_FALSE(fs::exists(half_written));
  EXPECT_EQ(slurp(sharded / "360" / "0001" / "distance.npy"),
            slurp(work_dir() / "data" / "360" / "0001" / "distance.npy"));
  for (const char* bad : {"2/2", "1", "a/2", "0/0", "-1/2"}) {
    const CliRun run = run_cli("synth --definition " + definition + " --shard " + bad + " --out " +
                               (work_dir() / "bad_shard").string());
    EXPECT_NE(run.status, 0) << bad;
    EXPECT_NE(run.err.find("--shard"), std::string::npos) << run.err;
  }
}

TEST_F(EvalCli, RandomOmniPointModelProducesTheTable) {
  const fs::path out = work_dir() / "eval_model";
  const CliRun run =
      run_cli("eval --model " + (work_dir() / "tiny.safetensors").string() + " --data " + data() +
              " --intrinsics --sparse-depth 30 --num-tokens 16 --out " + out.string());
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("ETA"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("6/6 samples"), std::string::npos) << run.err;
  const auto table = lines_of(slurp(out / "table.md"));
  ASSERT_EQ(table.size(), 6u) << slurp(out / "table.md");
  EXPECT_NE(table[0].find("360° metric δ1"), std::string::npos);
  const std::vector<std::string> modes{"none", "+K", "+D", "+K+D"};
  for (size_t i = 0; i < modes.size(); ++i)
    EXPECT_EQ(table[2 + i].rfind("| tiny | " + modes[i] + " |", 0), 0u) << table[2 + i];
  EXPECT_EQ(run.out, slurp(out / "table.md"));
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["samples_evaluated"], 6);
  EXPECT_EQ(summary["sparse_depth_points"], 30);
  EXPECT_EQ(summary["scores"].size(), 3u);
  const double rel = summary["scores"]["S.FoV"]["none"]["entries"]["depth_scale_invariant"]["rel"];
  EXPECT_GT(rel, 0.0);  // random weights are not the oracle
  EXPECT_EQ(lines_of(slurp(out / "samples.jsonl")).size(), 6u * 4u);
}

TEST_F(EvalCli, RandomModelFromAConfigIsSeeded) {
  std::ofstream(work_dir() / "tiny_config.json") << omnipoint::test::tiny_omnipoint_config_json();
  const auto table = [&](const std::string& name) {
    const CliRun run =
        run_cli("eval --random-model " + (work_dir() / "tiny_config.json").string() + " --data " +
                data() + " --num-tokens 16 --out " + (work_dir() / name).string());
    EXPECT_EQ(run.status, 0) << run.err;
    return slurp(work_dir() / name / "table.md");
  };
  const std::string first = table("eval_random_a");
  EXPECT_NE(first.find("| tiny_config (random weights) | none |"), std::string::npos) << first;
  EXPECT_EQ(first, table("eval_random_b"));  // same seed, same weights, same scores
  expect_one_error_line(
      run_cli("eval --random-model " + (work_dir() / "tiny.json").string() + " --data " + data() +
              " --out " + (work_dir() / "eval_random_bad").string()),
      "");
}

TEST_F(EvalCli, MoGe2CheckpointRunsThroughItsRaysAndDistances) {
  // The MoGe-2 parity fixture's tiny random-weight model: image only, so +K is reported not run.
  const fs::path out = work_dir() / "eval_moge2";
  const CliRun run = run_cli("eval --model " + std::string(OMNIPOINT_FIXTURE_DIR) +
                             "/moge2_forward_a/model.safetensors --label MoGe-2 --data " + data() +
                             " --intrinsics --num-tokens 16 --out " + out.string());
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("mode +K not run: MoGe-2 takes no such input"), std::string::npos)
      << run.err;
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["samples_evaluated"], 6);
  EXPECT_EQ(summary["modes"], nlohmann::json({"none"}));
  const auto& entries = summary["scores"]["L.FoV"]["none"]["entries"];
  EXPECT_TRUE(entries.contains("points_scale_invariant"));
  EXPECT_EQ(lines_of(slurp(out / "table.md")).size(), 3u);
}

TEST_F(EvalCli, ExternalPointMapsAreScoredLikeModels) {
  const fs::path predictions = work_dir() / "predictions";
  for (const auto& item : omnipoint::data::list_dataset(data())) {
    const auto sample = omnipoint::data::read_dataset_item(item, true);
    const at::Tensor points =
        sample.distance.unsqueeze(-1) * sample.camera.ray_map(at::kFloat).rays;
    fs::create_directories((predictions / item.id).parent_path());
    omnipoint::io::write_npy((predictions / (item.id + ".npy")).string(), points);
  }
  fs::remove(predictions / "360" / "0001.npy");
  const fs::path out = work_dir() / "eval_external";
  const CliRun run = run_cli("eval --predictions " + predictions.string() + " --data " + data() +
                             " --intrinsics --out " + out.string());
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("skipped 1 sample(s): missing prediction"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("mode +K not run"), std::string::npos) << run.err;
  const auto table = lines_of(slurp(out / "table.md"));
  ASSERT_EQ(table.size(), 3u);
  EXPECT_EQ(
      table[2],
      "| predictions | none | 0.00 | 100.0 | 0.00 | 100.0 | 100.0 | 0.00 | 100.0 | 0.00 | 100.0 | "
      "100.0 | 0.00 | 100.0 | 0.00 | 100.0 | 100.0 |");
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["samples_evaluated"], 5);
  EXPECT_EQ(summary["skipped"]["missing prediction"], 1);
}

TEST_F(EvalCli, SparseDepthDefaultsToOneThousandPoints) {
  const fs::path out = work_dir() / "eval_default_sparse";
  const CliRun run = run_cli("eval --baseline oracle --label Oracle --data " + data() +
                             " --sparse-depth --out " + out.string());
  ASSERT_EQ(run.status, 0) << run.err;
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["sparse_depth_points"], 1000);
  EXPECT_EQ(summary["modes"], nlohmann::json({"none", "+D"}));
  EXPECT_EQ(lines_of(slurp(out / "table.md"))[3].rfind("| Oracle | +D | 0.00 | 100.0 |", 0), 0u);
}

// The picture-blind baseline: the main set's per-pixel medians scored on the final set (the
// same cameras, other scenes); the oracle-free scores lie between the oracle's and chance.
TEST_F(EvalCli, MedianMapBaselineScoresTheFinalSetFromTheMainSet) {
  const fs::path final_set = work_dir() / "final";
  const CliRun synth = run_cli("synth --definition " + (work_dir() / "tiny.json").string() +
                               " --set final --out " + final_set.string());
  ASSERT_EQ(synth.status, 0) << synth.err;
  const fs::path out = work_dir() / "eval_median";
  // data(): the main set.
  const CliRun run = run_cli("eval --baseline median --baseline-data " + data() + " --data " +
                             final_set.string() + " --intrinsics --out " + out.string());
  ASSERT_EQ(run.status, 0) << run.err;
  const nlohmann::json summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary.at("samples_evaluated"), 6) << summary.dump();
  EXPECT_NE(summary.at("model").get<std::string>().find("median distance map"), std::string::npos);
  for (const char* split : {"S.FoV", "L.FoV", "360°"}) {
    const double rel = summary.at("scores")
                           .at(split)
                           .at("+K")
                           .at("entries")
                           .at("points_scale_invariant")
                           .at("rel")
                           .get<double>();
    EXPECT_GT(rel, 0.0) << split;
    EXPECT_LT(rel, 1.0) << split;
  }
}

TEST_F(EvalCli, BadInputsGiveOneClearLine) {
  const std::string out = " --out " + (work_dir() / "eval_bad").string();
  expect_one_error_line(
      run_cli("eval --baseline oracle --data " + (work_dir() / "missing").string() + out),
      "not a folder");
  fs::create_directories(work_dir() / "empty");
  expect_one_error_line(
      run_cli("eval --baseline oracle --data " + (work_dir() / "empty").string() + out),
      "no samples found");
  std::ofstream(work_dir() / "garbage.safetensors") << "this is not a safetensors file";
  expect_one_error_line(run_cli("eval --model " + (work_dir() / "garbage.safetensors").string() +
                                " --data " + data() + out),
                        "garbage.safetensors");
  expect_one_error_line(run_cli("eval --model " + (work_dir() / "nope.safetensors").string() +
                                " --data " + data() + out),
                        "nope.safetensors");
  expect_one_error_line(
      run_cli("eval --baseline oracle --model " + (work_dir() / "tiny.safetensors").string() +
              " --data " + data() + out),
      "exactly one of");
  expect_one_error_line(run_cli("eval --baseline best --data " + data() + out), "--baseline best");
  expect_one_error_line(run_cli("eval --baseline median --data " + data() + out),
                        "--baseline-data");
  expect_one_error_line(
      run_cli("eval --baseline constant --baseline-data " + data() + " --data " + data() + out),
      "--baseline median only");
  expect_one_error_line(
      run_cli("synth --benchmark " + (work_dir() / "tiny.json").string() + " --set nope" + out),
      "no set \"nope\"");
  EXPECT_FALSE(fs::exists(work_dir() / "eval_bad" / "summary.json"));
}

}  // namespace
