// TrainConfig on the field tables (util/config.h): the shipped configs (a base and the
// differences of each run), "extends" and --set through TrainConfig::load, enums and camera
// specs parsed once at load, the one-line errors with their key paths.
#include "omnipoint/train/train_config.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <unistd.h>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/atomic_file.h"
#include "support/cli_run.h"
#include "support/scratch_dir.h"
#include "support/tiny_omnipoint.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kRoot(OMNIPOINT_SOURCE_DIR);

json tiny_config() {
  return json::parse(R"({
    "model": {"conditioning": {}},
    "data": {"image_size": [28, 28], "num_tokens": [2, 4],
             "datasets": [{"synth": {"scenes": ["outdoor", "indoor"],
                                     "cameras": ["PINHOLE 28 28 20 20 14 14",
                                                 "OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0"]}}]},
    "stages": [{"stage": 1, "steps": 2}, {"stage": 2, "steps": 2}]})");
}

std::string error_of(const json& config) {
  try {
    TrainConfig::from_json(config);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// The leaves of a config's JSON that differ: objects are walked, arrays and "model" (the
// network's JSON, one setting) are compared whole.
void differences(const json& a, const json& b, const std::string& path,
                 std::set<std::string>& out) {
  if (a.is_object() && b.is_object() && path != "model") {
    for (const auto& [key, value] : a.items())
      differences(value, b.contains(key) ? b[key] : json(), path.empty() ? key : path + "." + key,
                  out);
    for (const auto& [key, value] : b.items())
      if (!a.contains(key)) out.insert(path.empty() ? key : path + "." + key);
  } else if (a != b) {
    out.insert(path);
  }
}

std::vector<fs::path> shipped_configs() {
  std::vector<fs::path> configs = {kRoot / "bench/train_default_before_issue16.json"};
  for (const auto& entry : fs::recursive_directory_iterator(kRoot / "examples" / "train"))
    if (entry.path().extension() == ".json") configs.push_back(entry.path());
  std::sort(configs.begin(), configs.end());
  return configs;
}

TEST(TrainConfig, EveryShippedConfigLoadsAndReadsBackFromItsJson) {
  const std::vector<fs::path> configs = shipped_configs();
  EXPECT_EQ(configs.size(), 30u);
  for (const fs::path& path : configs) {
    SCOPED_TRACE(path.string());
    const TrainConfig config = TrainConfig::load(path.string());
    const json written = config.to_json();
    EXPECT_FALSE(written.contains("extends"));
    EXPECT_EQ(TrainConfig::from_json(written).to_json(), written);
  }
}

// Each run that extends another states only what it changes; these are the changes, as
// docs/TRAINING.md and docs/ABLATIONS.md describe the runs.
TEST(TrainConfig, DerivedConfigsDifferFromTheirBaseInTheirDocumentedKeys) {
  using Keys = std::set<std::string>;
  const Keys fine_tune = {"data.datasets", "init.path", "output_dir", "seed", "stages"};
  const Keys s2_seed = {"augment.a2p_teacher", "init.path", "output_dir", "seed"};
  const Keys s2_loss = {"augment.a2p_teacher", "init.path", "loss.point_loss", "output_dir"};
  const std::map<std::string, Keys> expected = {
      {"default_model/omnipoint_default_longer.json",
       {"init.from", "init.path", "model", "output_dir", "seed", "stages"}},
      {"default_model/omnipoint_default_finetune.json", fine_tune},
      {"default_model/omnipoint_default_finetune2.json",
       {"init.path", "output_dir", "seed", "stages"}},
      {"default_model/omnipoint_default_finetune3.json", fine_tune},
      {"default_model/omnipoint_default_finetune4.json",
       {"conditions.probability", "data.datasets", "init.path", "output_dir", "seed", "stages"}},
      {"default_model/omnipoint_default_finetune5.json", fine_tune},
      {"default_model/omnipoint_default_finetune6.json",
       {"init.path", "output_dir", "seed", "stages"}},
      {"gpu/omnipoint_gpu.json",
       {"checkpoint_every", "data.batch_size", "data.datasets", "device", "eval_every", "log_every",
        "model", "output_dir", "precision", "stages", "threads"}},
      {"finetune_rig.json", {"augment.p2a",
                             "checkpoint_every",
                             "data.batch_size",
                             "data.datasets",
                             "data.eval_datasets",
                             "data.image_size",
                             "data.num_tokens",
                             "device",
                             "eval_at_start",
                             "eval_batches",
                             "eval_every",
                             "init.from",
                             "init.path",
                             "log_every",
                             "loss.weights.mask",
                             "model",
                             "output_dir",
                             "precision",
                             "stages",
                             "threads"}},
      {"sparse_lidar_demo.json",
       {"checkpoint_every", "data.batch_size", "data.datasets", "data.eval_datasets",
        "data.image_size", "data.num_tokens", "device", "ema.decay", "eval_batches", "eval_every",
        "log_every", "output_dir", "precision", "stages", "threads"}},
      {"ablations/s1_base_seed1.json", {"output_dir", "seed"}},
      {"ablations/s1_base_seed2.json", {"output_dir", "seed"}},
      {"ablations/s1_disjoint.json", {"loss.point_loss", "output_dir"}},
      {"ablations/s1_naive.json", {"loss.point_loss", "output_dir"}},
      {"ablations/s1_xyz.json", {"model", "output_dir"}},
      {"ablations/s2_base_seed0.json",
       {"augment.a2p", "augment.a2p_teacher", "augment.a2p_teacher_tokens", "augment.p2a",
        "augment.p2a_probability", "conditions.sparse_ratio", "data.datasets", "init.from",
        "init.path", "model", "output_dir", "seed", "stages"}},
      {"ablations/s2_base_seed1.json", s2_seed},
      {"ablations/s2_base_seed2.json", s2_seed},
      {"ablations/s2_disjoint.json", s2_loss},
      {"ablations/s2_naive.json", s2_loss},
      {"ablations/s2_xyz.json", {"augment.a2p_teacher", "init.path", "output_dir"}},
      {"ablations/s2_a2p_only.json", {"augment.p2a", "augment.p2a_probability", "output_dir"}},
      {"ablations/s2_p2a_only.json",
       {"augment.a2p", "augment.a2p_teacher", "augment.a2p_teacher_tokens", "data.datasets",
        "output_dir"}},
      {"ablations/s2_no_p2a_no_a2p.json",
       {"augment.a2p", "augment.a2p_teacher", "augment.a2p_teacher_tokens", "augment.p2a",
        "augment.p2a_probability", "data.datasets", "output_dir"}},
      {"ablations/s2_no_smoothing.json", {"model", "output_dir"}},
      {"ablations/s2_no_state_embeddings.json", {"model", "output_dir"}}};
  const fs::path train = kRoot / "examples" / "train";
  std::set<std::string> derived;
  for (const fs::path& path : shipped_configs()) {
    const json raw = json::parse(io::read_file(path.string()));
    if (!raw.contains("extends")) continue;
    const std::string name = fs::relative(path, train).string();
    derived.insert(name);
    SCOPED_TRACE(name);
    const fs::path base = path.parent_path() / raw["extends"].get<std::string>();
    std::set<std::string> changed;
    differences(TrainConfig::load(base.string()).to_json(),
                TrainConfig::load(path.string()).to_json(), "", changed);
    ASSERT_TRUE(expected.count(name)) << "a derived config without its documented changes";
    EXPECT_EQ(changed, expected.at(name));
  }
  EXPECT_EQ(derived.size(), expected.size());
}

TEST(TrainConfig, EnumsAndCamerasAreParsedAtLoad) {
  json text = tiny_config();
  text["device"] = "cuda";
  text["precision"] = "bf16";
  text["init"] = {{"from", "moge2"}, {"path", "moge2.safetensors"}, {"output", "xyz"}};
  text["loss"] = {{"point_loss", "disjoint"}};
  text["stages"][1]["schedule"] = "flat_cosine";
  const TrainConfig config = TrainConfig::from_json(text);
  EXPECT_EQ(config.device, TrainDevice::kCuda);
  EXPECT_EQ(config.precision, model::Precision::kBFloat16);
  EXPECT_EQ(config.init_from, InitSource::kMoGe2);
  EXPECT_EQ(config.init_output, model::OutputKind::kXyz);
  EXPECT_EQ(config.loss.point_loss, PointLoss::kDisjoint);
  EXPECT_EQ(config.stages[1].schedule, Schedule::kFlatCosine);
  const SynthSource& synth = config.datasets[0].synth_source;
  EXPECT_EQ(synth.scenes, (std::vector<data::synth::SceneKind>{data::synth::SceneKind::kOutdoor,
                                                               data::synth::SceneKind::kIndoor}));
  ASSERT_EQ(synth.cameras.size(), 2u);
  EXPECT_EQ(synth.cameras[1], camera::parse_camera("OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0"));
  // The written config names them as the file does, the cameras as their spec lines.
  const json written = config.to_json();
  EXPECT_EQ(written["device"], "cuda");
  EXPECT_EQ(written["init"]["output"], "xyz");
  EXPECT_EQ(written["data"]["datasets"][0]["synth"]["cameras"][0],
            camera::parse_camera("PINHOLE 28 28 20 20 14 14").to_spec());
  EXPECT_EQ(written["data"]["datasets"][0]["image_size"], json::parse("[28, 28]"));

  // A camera file is read once too, relative to the working directory as before.
  const fs::path file =
      fs::temp_directory_path() / ("omnipoint_train_camera_" + std::to_string(::getpid()) + ".txt");
  std::ofstream(file) << "1 PINHOLE 28 28 20 20 14 14\n";
  text = tiny_config();
  text["data"]["datasets"][0]["synth"]["cameras"] = {file.string()};
  EXPECT_EQ(TrainConfig::from_json(text).datasets[0].synth_source.cameras.at(0),
            camera::parse_camera("PINHOLE 28 28 20 20 14 14"));
  fs::remove(file);
}

TEST(TrainConfig, ErrorsNameTheKeyPath) {
  const auto changed = [](const std::function<void(json&)>& change) {
    json config = tiny_config();
    change(config);
    return error_of(config);
  };
  EXPECT_EQ(changed([](json& c) { c["threads"] = 1e300; }),
            "training config: threads: expected an integer in range [-2147483648, 2147483647], "
            "got 1e+300");
  EXPECT_EQ(changed([](json& c) { c["threads"] = 0; }),
            "training config: threads: must be at least 1");
  EXPECT_EQ(changed([](json& c) { c["stages"][1]["steps"] = 0; }),
            "training config: stages[1].steps: must be at least 1");
  EXPECT_EQ(changed([](json& c) { c["stages"][1]["warmup_steps"] = 2; }),
            "training config: stages[1].warmup_steps: must lie in [0, steps)");
  EXPECT_EQ(changed([](json& c) { c["device"] = "gpu"; }),
            "training config: device: expected one of cpu, cuda, got \"gpu\"");
  EXPECT_EQ(changed([](json& c) {
              c["init"] = {{"from", "moge2"}, {"output", "depth"}};
            }),
            "training config: init.output: expected one of ray_distance, xyz, got \"depth\"");
  EXPECT_EQ(changed([](json& c) {
              c["init"] = {{"from", "omnipoint"}};
            }),
            "training config: init.path: required to initialise from omnipoint");
  EXPECT_EQ(changed([](json& c) { c["data"]["datasets"][0]["synth"]["scenes"] = {"forest"}; }),
            "training config: data.datasets[0].synth.scenes[0]: expected one of indoor, "
            "outdoor, object, got \"forest\"");
  EXPECT_EQ(changed([](json& c) { c["data"]["datasets"][0]["synth"]["cameras"] = json::array(); }),
            "training config: data.datasets[0].synth.cameras: must not be empty");
  EXPECT_EQ(changed([](json& c) { c["data"]["datasets"][0]["folders"] = "pool"; }),
            "training config: data.datasets[0]: needs exactly one of \"synth\", \"folders\" or "
            "\"format\"");
  EXPECT_EQ(changed([](json& c) {
              c["data"]["datasets"][0]["image_size"] = {28, 1};
            }),
            "training config: data.datasets[0].image_size: must be [width, height], at least 2 "
            "each");
  EXPECT_EQ(changed([](json& c) { c["data"].erase("datasets"); }),
            "training config: data.datasets: expected a non-empty array of data sources");
  EXPECT_EQ(changed([](json& c) { c.erase("stages"); }),
            "training config: stages: expected a non-empty array of training stages");
  EXPECT_EQ(changed([](json& c) {
              c["loss"] = {{"local", {{"levels", {4, 0}}}}};
            }),
            "training config: loss.local.levels: must be positive");
  EXPECT_EQ(changed([](json& c) {
              c["optimizer"] = {{"eps", "small"}};
            }),
            "training config: optimizer.eps: expected a finite number, got \"small\"");
  const std::string camera =
      changed([](json& c) { c["data"]["datasets"][0]["synth"]["cameras"][1] = "FISHEYE 28 28"; });
  EXPECT_EQ(camera.rfind("training config: data.datasets[0].synth.cameras[1]: ", 0), 0u) << camera;
  EXPECT_EQ(camera.find('\n'), std::string::npos);
}

// A dataset in its native layout: read and written through the source table (the folders form
// stays as it was written), held-out sources beside the training ones, and one error line
// naming the key for each mistake.
TEST(TrainConfig, NativeSourcesRoundTripAndBadKeysNameTheirPath) {
  json config = tiny_config();
  config["data"]["datasets"].push_back(
      {{"weight", 3},
       {"format", "kitti-raw"},
       {"root", "data/drives"},
       {"split", "data/drives/train_files.txt"},
       {"options", {{"camera", "image_03"}, {"principal_point", "corner"}}},
       {"image_size", {64, 20}}});
  config["data"]["datasets"].push_back({{"folders", "data/pool"}});
  config["data"]["datasets"].push_back({{"format", "folders"}, {"root", "data/pool"}});
  config["data"]["eval_datasets"] = {
      {{"format", "kitti-raw"}, {"root", "data/drives"}, {"split", "data/drives/test.txt"}}};
  config["eval_at_start"] = true;
  const TrainConfig read = TrainConfig::from_json(config);
  ASSERT_EQ(read.datasets.size(), 4u);
  const DatasetSource& native = read.datasets[1];
  EXPECT_FALSE(native.synth);
  EXPECT_EQ(native.format, "kitti-raw");
  EXPECT_EQ(native.root, "data/drives");
  EXPECT_EQ(native.split, "data/drives/train_files.txt");
  EXPECT_EQ(native.options, (std::map<std::string, std::string>{{"camera", "image_03"},
                                                                {"principal_point", "corner"}}));
  EXPECT_EQ(native.weight, 3.0);
  EXPECT_EQ(native.width, 64);
  EXPECT_EQ(native.height, 20);
  EXPECT_EQ(read.datasets[2].folders, "data/pool");
  EXPECT_TRUE(read.datasets[2].format.empty());
  EXPECT_EQ(read.datasets[3].format, "folders");
  ASSERT_EQ(read.eval_datasets.size(), 1u);
  EXPECT_EQ(read.eval_datasets[0].split, "data/drives/test.txt");
  EXPECT_EQ(read.eval_datasets[0].width, 28);  // data.image_size
  EXPECT_TRUE(read.eval_at_start);

  const json written = read.to_json();
  EXPECT_EQ(written["data"]["datasets"][1],
            json::parse(R"({"weight": 3.0, "format": "kitti-raw", "root": "data/drives",
                            "split": "data/drives/train_files.txt",
                            "options": {"camera": "image_03", "principal_point": "corner"},
                            "image_size": [64, 20], "labels": true})"));
  EXPECT_EQ(written["data"]["datasets"][2],
            json::parse(R"({"weight": 1.0, "folders": "data/pool", "image_size": [28, 28],
                            "labels": true})"));
  EXPECT_EQ(TrainConfig::from_json(written).to_json(), written);
  // Without held-out sources the key is left out, as before it existed.
  EXPECT_FALSE(TrainConfig::from_json(tiny_config()).to_json()["data"].contains("eval_datasets"));

  const auto changed = [](const std::function<void(json&)>& change) {
    json c = tiny_config();
    c["data"]["datasets"][0] = {{"format", "kitti-raw"}, {"root", "data/drives"}};
    change(c);
    return error_of(c);
  };
  EXPECT_EQ(changed([](json&) {}), "");
  const std::string unknown =
      changed([](json& c) { c["data"]["datasets"][0]["format"] = "kitti_raw"; });
  EXPECT_EQ(unknown.rfind("training config: data.datasets[0].format: unknown dataset format "
                          "\"kitti_raw\" (known: ",
                          0),
            0u)
      << unknown;
  EXPECT_NE(unknown.find("kitti-raw"), std::string::npos) << unknown;
  EXPECT_EQ(unknown.find('\n'), std::string::npos);
  EXPECT_EQ(changed([](json& c) {
              c["data"]["datasets"][0]["options"] = {{"cam", "image_02"}};
            }),
            "training config: data.datasets[0].options.cam: not an option of format "
            "\"kitti-raw\" (its options: camera, principal_point)");
  EXPECT_EQ(changed([](json& c) {
              c["data"]["datasets"][0]["options"] = {{"camera", 2}};
            }),
            "training config: data.datasets[0].options.camera: expected a string, got 2");
  EXPECT_EQ(changed([](json& c) { c["data"]["datasets"][0].erase("root"); }),
            "training config: data.datasets[0].root: required with \"format\" (the dataset's "
            "root folder)");
  EXPECT_EQ(changed([](json& c) {
              c["data"]["datasets"][0] = {{"folders", "pool"}, {"split", "a.txt"}};
            }),
            "training config: data.datasets[0].split: only with \"format\"");
  EXPECT_EQ(changed([](json& c) { c["data"]["datasets"][0]["folders"] = "pool"; }),
            "training config: data.datasets[0]: needs exactly one of \"synth\", \"folders\" or "
            "\"format\"");
  EXPECT_EQ(
      changed([](json& c) {
        c["data"]["eval_datasets"] = {{{"format", "kitti-raw"}, {"root", "d"}, {"labels", false}}};
      }),
      "training config: data.eval_datasets[0].labels: an evaluation source needs labels");
  EXPECT_EQ(changed([](json& c) {
              c["data"]["eval_datasets"] = {{{"format", "moge"}, {"root", "d"}, {"optoins", {}}}};
            }),
            "training config: data.eval_datasets[0].optoins: unknown key (expected \"weight\", "
            "\"synth\", \"folders\", \"format\", \"root\", \"split\", \"options\", "
            "\"image_size\" or \"labels\")");
}

class TrainConfigFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("omnipoint_train_config_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "runs");
    std::ofstream(dir_ / "base.json") << tiny_config().dump();
    std::ofstream(dir_ / "runs" / "longer.json")
        << R"({"extends": "../base.json", "seed": 3, "stages": [{"stage": 1, "steps": 10}]})";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string error_of_load(const std::vector<std::string>& overrides) {
    try {
      TrainConfig::load((dir_ / "runs" / "longer.json").string(), overrides);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(TrainConfigFiles, LoadMergesTheBaseAndAppliesOverrides) {
  const std::string path = (dir_ / "runs" / "longer.json").string();
  const TrainConfig config = TrainConfig::load(path);
  EXPECT_EQ(config.seed, 3u);
  ASSERT_EQ(config.stages.size(), 1u);  // an array replaces the base's
  EXPECT_EQ(config.stages[0].steps, 10);
  EXPECT_EQ(config.width, 28);  // from the base

  const TrainConfig changed =
      TrainConfig::load(path, {"stages[0].steps=2000", "data.batch_size=3", "device=cuda",
                               "output_dir=runs/b", "stages.0.lr_heads=1e-3"});
  EXPECT_EQ(changed.stages[0].steps, 2000);
  EXPECT_EQ(changed.stages[0].lr_heads, 1e-3);
  EXPECT_EQ(changed.batch_size, 3);
  EXPECT_EQ(changed.device, TrainDevice::kCuda);
  EXPECT_EQ(changed.output_dir, "runs/b");
  // The resolved config is every key; it loads back to the same config.
  EXPECT_EQ(TrainConfig::from_json(changed.to_json()).to_json(), changed.to_json());
}

TEST_F(TrainConfigFiles, OverridesAreCheckedLikeTheFile) {
  const std::string path = (dir_ / "runs" / "longer.json").string();
  EXPECT_EQ(error_of_load({"data.bogus=1"})
                .rfind("config " + path + ": training config: data.bogus: unknown key", 0),
            0u)
      << error_of_load({"data.bogus=1"});
  EXPECT_EQ(error_of_load({"stages[0].steps=many"}),
            "config " + path +
                ": training config: stages[0].steps: expected an integer in range "
                "[-9223372036854775808, 9223372036854775807], got \"many\"");
  EXPECT_EQ(error_of_load({"stages[3].steps=1"}), "--set stages[3].steps=1: stages has 1 entries");
  EXPECT_EQ(error_of_load({"seed"}), "--set seed: expected KEY=VALUE");
}

// `omnipoint train --set`: the overrides reach the run (and each --nproc rank), a bad one is
// one error line and a failed exit.
TEST(TrainCli, SetOverridesKeysOfTheConfig) {
  const fs::path dir = test::fresh_process_dir("omnipoint_train_set");
  json config = tiny_config();
  config["model"] = json::parse(
      test::tiny_omnipoint_config_json("ray_distance", R"({"encoder_dim": 8, "splat_radius": 2})"));
  config["output_dir"] = (dir / "unused").string();
  config["stages"] = {{{"stage", 1}, {"steps", 50}}, {{"stage", 2}, {"steps", 50}}};
  config["checkpoint_every"] = 0;
  std::ofstream(dir / "run.json") << config.dump();
  const std::string run = "train --config " + (dir / "run.json").string();

  const test::CliRun trained =
      test::run_omnipoint(run + " --set output_dir=" + (dir / "set").string() +
                              " --set stages[0].steps=1 --set stages.1.steps=1 --set log_every=1",
                          dir / "cli");
  ASSERT_EQ(trained.status, 0) << trained.err;
  EXPECT_FALSE(fs::exists(dir / "unused"));
  std::istringstream log(test::slurp(dir / "set" / "log.jsonl"));
  int records = 0;
  for (std::string line; std::getline(log, line);)
    records += line.find("\"loss\"") != std::string::npos;
  EXPECT_EQ(records, 2);  // 1 + 1 steps

  const test::CliRun bad = test::run_omnipoint(run + " --set data.bogus=1", dir / "cli");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find("training config: data.bogus: unknown key"), std::string::npos) << bad.err;
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  const test::CliRun malformed = test::run_omnipoint(run + " --set stages", dir / "cli");
  EXPECT_NE(malformed.status, 0);
  EXPECT_NE(malformed.err.find("--set stages: expected KEY=VALUE"), std::string::npos)
      << malformed.err;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace omnipoint::train
