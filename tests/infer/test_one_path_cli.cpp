// End to end through the tool: what `omnipoint eval` scores is what `omnipoint predict` ships.
// For the bundled model and the MoGe-2 fixture, on a pinhole, a fisheye and a panorama sample
// rendered by `omnipoint synth`, in every condition mode eval runs (MoGe-2 takes no camera: +K
// and +K+D are reported as not run), eval's scored point map (--save-points) equals predict's
// points.npy for the same image, camera and sparse distances (eval's, given to predict as a
// radial-distance map), and eval's per-sample scores equal `omnipoint metrics` on predict's files.
// Eval scores the network's mask as MoGe's evaluation does, without the flying-pixel filter that
// predict applies by default, so predict runs here with --edge-threshold 0.
#include <gtest/gtest.h>

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/data/sample.h"
#include "omnipoint/io/npy.h"
#include "support/cli_run.h"

namespace {
namespace fs = std::filesystem;

using omnipoint::test::CliRun;

const fs::path& work_dir() {
  static const fs::path dir = omnipoint::test::fresh_process_dir("omnipoint_one_path_cli");
  return dir;
}

CliRun run_cli(const std::string& args) {
  return omnipoint::test::run_omnipoint(args, work_dir());
}

std::string quoted(const std::string& text) {
  return "'" + text + "'";
}

// One dataset folder per camera kind, one sample each.
const std::vector<fs::path>& datasets() {
  static const std::vector<fs::path> roots = [] {
    const std::vector<std::pair<std::string, std::string>> cameras = {
        {"pinhole", "PINHOLE 48 36 40 40 24 18"},
        {"fisheye", "OPENCV_FISHEYE 48 36 13 13 24 18 0 0 0 0"},
        {"panorama", "EQUIRECTANGULAR 64 32"}};
    std::vector<fs::path> made;
    for (const auto& [name, spec] : cameras) {
      const fs::path root = work_dir() / "data" / name;
      const CliRun run =
          run_cli("synth --camera " + quoted(spec) +
                  " --scene indoor --seed 3 --count 1 --no-shadows --no-ao --out " + root.string());
      EXPECT_EQ(run.status, 0) << run.err;
      made.push_back(root);
    }
    return made;
  }();
  return roots;
}

nlohmann::json parse_json(const std::string& text, const std::string& what) {
  try {
    return nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": " << e.what() << "\n" << text;
    return nlohmann::json::object();
  }
}

// The ground truth eval scores against (runner.h): points d·r, depth z on S.FoV and the
// radial distance on the wide splits, the sample's mask within the camera's domain.
struct GroundTruthFiles {
  std::string depth, points, mask;
};

GroundTruthFiles write_ground_truth(const fs::path& sample_folder, const std::string& split,
                                    const fs::path& dir) {
  const omnipoint::data::Sample sample = omnipoint::data::read_sample(sample_folder.string());
  const auto ray_map = sample.camera.ray_map(at::kFloat);
  const at::Tensor points = sample.distance.unsqueeze(-1) * ray_map.rays;
  const at::Tensor depth = split == "S.FoV" ? points.select(-1, 2).contiguous() : sample.distance;
  fs::create_directories(dir);
  const GroundTruthFiles files{(dir / "gt_depth.npy").string(), (dir / "gt_points.npy").string(),
                               (dir / "gt_mask.npy").string()};
  omnipoint::io::write_npy(files.depth, depth);
  omnipoint::io::write_npy(files.points, points);
  omnipoint::io::write_npy(files.mask, (sample.mask & ray_map.valid).contiguous());
  return files;
}

void expect_same_scores(const nlohmann::json& eval_entries, const nlohmann::json& metrics,
                        const std::string& what) {
  ASSERT_EQ(eval_entries.size(), metrics.size()) << what << "\n" << metrics.dump();
  for (const auto& [name, score] : eval_entries.items()) {
    ASSERT_TRUE(metrics.contains(name)) << what << " " << name;
    for (const char* key : {"rel", "delta1"}) {
      const nlohmann::json &a = score.at(key), &b = metrics.at(name).at(key);
      if (a.is_null() || b.is_null()) {
        EXPECT_EQ(a.is_null(), b.is_null()) << what << " " << name << " " << key;
      } else {
        EXPECT_NEAR(a.get<double>(), b.get<double>(), 1e-5) << what << " " << name << " " << key;
      }
    }
  }
}

void expect_eval_is_predict(const std::string& label, const std::string& model,
                            const std::string& tokens, const std::vector<std::string>& modes) {
  std::string data;
  for (const fs::path& root : datasets()) data += " " + root.string();
  const fs::path eval_out = work_dir() / label / "eval";
  const CliRun eval = run_cli("eval --model " + model + " --data" + data +
                              " --intrinsics --sparse-depth 30 --save-points" + tokens + " --out " +
                              eval_out.string());
  ASSERT_EQ(eval.status, 0) << eval.err;

  std::map<std::string, int> runs;  // mode -> samples compared
  std::stringstream records(omnipoint::test::slurp(eval_out / "samples.jsonl"));
  for (std::string line; std::getline(records, line);) {
    const nlohmann::json record = parse_json(line, "samples.jsonl");
    ASSERT_FALSE(record.contains("skipped")) << line;
    const fs::path root = record.at("dataset").get<std::string>();
    const std::string id = record.at("id"), mode = record.at("mode"), split = record.at("split");
    const std::string what = label + " " + root.filename().string() + " " + mode;
    ++runs[mode];

    // predict on the same image with the mode's inputs: the sample's camera for +K, eval's
    // sparse distances for +D.
    const fs::path sample = root / id;
    const fs::path saved = eval_out / "points" / root.filename() / id / mode;
    const fs::path predict_out = work_dir() / label / "predict" / root.filename() / mode;
    std::string args = "predict " + (sample / "image.png").string() + " --model " + model + tokens +
                       " --fit-model none --edge-threshold 0 --out " + quoted(predict_out.string());
    if (mode.find("+K") != std::string::npos) {
      const nlohmann::json meta =
          parse_json(omnipoint::test::slurp(sample / "meta.json"), "meta.json");
      args += " --camera " + quoted(meta.at("camera").get<std::string>());
    }
    if (mode.find("+D") != std::string::npos)
      args += " --sparse-depth " + quoted((saved / "sparse_distance.npy").string()) +
              " --sparse-depth-radial";
    const CliRun predict = run_cli(args);
    ASSERT_EQ(predict.status, 0) << what << "\n" << predict.err;
    const fs::path shipped = predict_out / "image";

    const at::Tensor scored = omnipoint::io::read_npy((saved / "points.npy").string());
    const at::Tensor points = omnipoint::io::read_npy((shipped / "points.npy").string());
    ASSERT_EQ(scored.sizes(), points.sizes()) << what;
    EXPECT_LE((scored - points).abs().max().item<double>(), 1e-6) << what;

    // Eval's scores are `omnipoint metrics` on predict's files.
    const GroundTruthFiles gt = write_ground_truth(sample, split, saved);
    const bool metric = record.at("entries").contains("points_metric");
    const CliRun metrics =
        run_cli("metrics --gt-depth " + quoted(gt.depth) + " --pred-depth " +
                quoted((shipped / (split == "S.FoV" ? "depth.npy" : "distance.npy")).string()) +
                " --gt-points " + quoted(gt.points) + " --pred-points " +
                quoted((shipped / "points.npy").string()) + " --mask " + quoted(gt.mask) +
                (metric ? " --metric" : ""));
    ASSERT_EQ(metrics.status, 0) << what << "\n" << metrics.err;
    expect_same_scores(record.at("entries"), parse_json(metrics.out, "metrics"), what);
  }
  std::map<std::string, int> expected;
  for (const std::string& mode : modes) expected[mode] = 3;
  EXPECT_EQ(runs, expected) << label;
}

TEST(OnePathCli, EvalScoresWhatPredictShipsBundledModel) {
  // At the model's own default token budget on both sides (no --num-tokens).
  expect_eval_is_predict(
      "bundled", std::string(OMNIPOINT_SOURCE_DIR) + "/models/omnipoint_default.safetensors", "",
      {"none", "+K", "+D", "+K+D"});
}

TEST(OnePathCli, EvalScoresWhatPredictShipsMoGe2) {
  const std::string model =
      std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/model.safetensors";
  expect_eval_is_predict("moge2", model, " --num-tokens 64", {"none", "+D"});
  // The camera is no MoGe-2 input: eval says so instead of scoring +K.
  const nlohmann::json summary = parse_json(
      omnipoint::test::slurp(work_dir() / "moge2" / "eval" / "summary.json"), "summary.json");
  EXPECT_EQ(summary.at("modes_not_supported"), nlohmann::json({"+K", "+K+D"}));
}

}  // namespace
