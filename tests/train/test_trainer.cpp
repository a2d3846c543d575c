// The training configuration and the training loop on a tiny network and synthetic data:
// config errors, schedules, stage 3 freezing, EMA, evaluation, non-finite step handling and
// the exact restore in memory.
#include <ATen/ATen.h>
#include <ATen/Context.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/train/trainer.h"
#include "train/tiny_training.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(TrainConfig, RejectsBadConfigsClearly) {
  json config = tiny_config("x");
  config["augment"] = {{"a2p", true}};
  try {
    TrainConfig::from_json(config);
    FAIL() << "A2P without a teacher accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("augment.a2p_teacher"), std::string::npos) << e.what();
  }
  config["augment"] = {{"p2a", true}, {"p2a_probability", 1.5}};
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
  config["augment"] = {{"p2a", true}, {"p2a_probabilty", 0.5}};
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
  config = tiny_config("x");
  config["stages"][0]["learning_rate"] = 1;
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
  config = tiny_config("x");
  config["stages"][0]["stage"] = 4;
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
  config = tiny_config("x");
  config["data"]["datasets"][0].erase("synth");
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
  config = tiny_config("x");
  config["loss"]["point_loss"] = "entangled";
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
  config = tiny_config("x");
  config["device"] = "gpu";
  try {
    TrainConfig::from_json(config);
    FAIL() << "device \"gpu\" accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("device"), std::string::npos) << e.what();
  }
}

TEST(TrainConfig, ScheduleFactorsAndNewKeys) {
  json config = tiny_config("x");
  config["stages"][1] = {{"stage", 2},
                         {"steps", 11},
                         {"lr_backbone", 1e-3},
                         {"lr_heads", 1e-3},
                         {"schedule", "flat_cosine"},
                         {"flat_fraction", 0.5},
                         {"final_factor", 0.1},
                         {"warmup_steps", 1}};
  const StageConfig stage = TrainConfig::from_json(config).stages[1];
  EXPECT_DOUBLE_EQ(stage.lr_factor(0), 0.5);  // warm-up: (0 + 1) / (1 + 1)
  EXPECT_DOUBLE_EQ(stage.lr_factor(1), 1.0);
  EXPECT_DOUBLE_EQ(stage.lr_factor(5), 1.0);  // flat to step 5.5
  // Half a cosine from 5.5 to the last step, 10: 1 at its start, (1 + 0.1) / 2 half way.
  EXPECT_NEAR(stage.lr_factor(10), 0.1, 1e-12);
  EXPECT_NEAR(stage.lr_factor(8), 0.1 + 0.9 * 0.5 * (1 + std::cos(M_PI * 2.5 / 4.5)), 1e-12);
  EXPECT_GT(stage.lr_factor(7), stage.lr_factor(8));
  const StageConfig step = TrainConfig::from_json(tiny_config("x")).stages[0];
  EXPECT_DOUBLE_EQ(step.lr_factor(0), 1.0);
  EXPECT_DOUBLE_EQ(step.lr_factor(1), 0.5);  // decay_every 1, the paper's step schedule
  for (const auto& [key, value] : std::vector<std::pair<std::string, json>>{{"schedule", "linear"},
                                                                            {"flat_fraction", 1.5},
                                                                            {"final_factor", -0.1},
                                                                            {"warmup_steps", 11}}) {
    json bad = config;
    bad["stages"][1][key] = value;
    try {
      TrainConfig::from_json(bad);
      FAIL() << key << " " << value.dump() << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  json unlabelled = tiny_config("x");
  unlabelled["data"]["datasets"][0]["labels"] = false;
  try {
    TrainConfig::from_json(unlabelled);
    FAIL() << "an unlabelled source without A2P accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("augment.a2p"), std::string::npos) << e.what();
  }
  json sized = tiny_config("x");
  sized["data"]["datasets"][0]["image_size"] = {28};
  EXPECT_THROW(TrainConfig::from_json(sized), std::invalid_argument);
}

// Every config the repository ships (recipes, ablations, benchmarks) parses with today's keys,
// and the bundled model's architecture file is the default recipe's network.
TEST(TrainConfig, ShippedConfigsParse) {
  const fs::path root(OMNIPOINT_SOURCE_DIR);
  std::vector<std::string> configs = {(root / "bench/train_default_before_issue16.json").string()};
  for (const auto& entry : fs::recursive_directory_iterator(root / "examples" / "train"))
    if (entry.path().extension() == ".json") configs.push_back(entry.path().string());
  for (const std::string& path : configs) EXPECT_NO_THROW(TrainConfig::load(path)) << path;
  EXPECT_GE(configs.size(), 4u);
  const auto read_json = [&](const char* path) {
    return json::parse(io::read_file((root / path).string()));
  };
  EXPECT_EQ(read_json("examples/train/default_model/omnipoint_default.json")["model"],
            read_json("benchmarks/models/omnipoint_default_arch.json"));
}

// The evaluation scores the EMA weights, and leaves the live weights as they were.
TEST(Trainer, EvaluatesTheEmaWeights) {
  json json_config = tiny_config("x");
  json_config["eval_batches"] = 2;
  const TrainConfig config = TrainConfig::from_json(json_config);
  Trainer trainer(config, tiny_model(config));
  for (int i = 0; i < 3; ++i) trainer.train_step();
  std::map<std::string, at::Tensor> live;
  for (const auto& [name, t] : model::state_dict(*trainer.model())) live[name] = t.clone();
  ASSERT_FALSE(at::equal(live.at("encoder.backbone.cls_token"),
                         trainer.ema().at("encoder.backbone.cls_token")));
  const std::map<std::string, double> scores = trainer.evaluate();
  for (const auto& [name, t] : model::state_dict(*trainer.model()))
    EXPECT_TRUE(at::equal(t, live.at(name))) << name << " not restored";

  // At the same step, a trainer whose weights and EMA are the first one's EMA scores exactly
  // the same; one whose weights and EMA are the first one's live weights does not.
  const auto scores_of = [&](const std::map<std::string, at::Tensor>& weights) {
    TrainState state = trainer.state();
    for (const auto& [name, t] : weights) state.model[name] = state.ema[name] = t.clone();
    Trainer other(config, tiny_model(config));
    other.restore(state);
    return other.evaluate();
  };
  EXPECT_EQ(scores_of(trainer.ema()), scores);
  EXPECT_NE(scores_of(live).at("loss"), scores.at("loss"));
  EXPECT_TRUE(std::isfinite(scores.at("loss")));
}

// "device": "cuda" where this LibTorch has none: one clear error before any work.
TEST(Trainer, CudaWithoutCudaIsOneClearError) {
  if (at::hasCUDA()) GTEST_SKIP() << "this build has CUDA";
  json json_config = tiny_config("x");
  json_config["device"] = "cuda";
  const TrainConfig config = TrainConfig::from_json(json_config);
  try {
    Trainer trainer(config, tiny_model(config));
    FAIL() << "a CUDA trainer was made without CUDA";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "training: device \"cuda\": this build has no CUDA (LibTorch without CUDA, or no "
              "GPU visible); use \"cpu\"");
  }
}

// On a GPU the same steps from the same weights and batches give the losses the CPU gives
// (within float rounding: the kernels differ), and the evaluation runs; the checkpoint state
// comes back to the CPU.
TEST(Trainer, CudaTrainsLikeTheCpu) {
  if (!at::hasCUDA()) GTEST_SKIP() << "no CUDA in this build";
  json json_config = tiny_config("x");
  json_config["eval_batches"] = 1;
  const TrainConfig cpu_config = TrainConfig::from_json(json_config);
  json_config["device"] = "cuda";
  const TrainConfig cuda_config = TrainConfig::from_json(json_config);
  Trainer on_cpu(cpu_config, tiny_model(cpu_config));
  Trainer on_cuda(cuda_config, tiny_model(cuda_config));
  for (int step = 0; step < 3; ++step) {
    const StepRecord cpu = on_cpu.train_step(), cuda = on_cuda.train_step();
    ASSERT_TRUE(std::isfinite(cuda.loss)) << "step " << step;
    EXPECT_NEAR(cuda.loss, cpu.loss, 1e-3 * std::abs(cpu.loss) + 1e-5) << "step " << step;
  }
  const auto cpu_scores = on_cpu.evaluate(), cuda_scores = on_cuda.evaluate();
  EXPECT_NEAR(cuda_scores.at("loss"), cpu_scores.at("loss"),
              1e-2 * std::abs(cpu_scores.at("loss")));
  for (const auto& [name, tensor] : on_cuda.state().ema) EXPECT_TRUE(tensor.is_cpu()) << name;
}

TEST(Trainer, StageTwoTrainsWithP2AAndA2P) {
  const std::string dir = temp_dir("p2a_a2p");
  const TrainConfig base = TrainConfig::from_json(tiny_config("x"));
  const model::OmniPointModel teacher = tiny_model(base);
  io::write_safetensors(dir + "/teacher.safetensors", model::state_dict(*teacher),
                        model::omnipoint_metadata(teacher->config()));
  json json_config = tiny_config(dir);
  json_config["augment"] = {{"p2a", true},
                            {"p2a_probability", 0.5},
                            {"a2p", true},
                            {"a2p_teacher", dir + "/teacher.safetensors"}};
  const TrainConfig config = TrainConfig::from_json(json_config);
  Trainer trainer(config, tiny_model(config));
  while (!trainer.done()) {
    const StepRecord record = trainer.train_step();
    EXPECT_FALSE(record.skipped) << "step " << record.step;
    EXPECT_TRUE(std::isfinite(record.loss)) << "step " << record.step;
  }
  fs::remove_all(dir);
}

TEST(Trainer, ScheduleEmaAndStageThreeFreezing) {
  const TrainConfig config = TrainConfig::from_json(tiny_config("x"));
  Trainer trainer(config, tiny_model(config));
  const std::map<std::string, at::Tensor> before = [&] {
    std::map<std::string, at::Tensor> copy;
    for (const auto& [name, t] : model::state_dict(*trainer.model())) copy[name] = t.clone();
    return copy;
  }();
  const StepRecord first = trainer.train_step();
  EXPECT_EQ(first.step, 1);
  EXPECT_FALSE(first.skipped);
  EXPECT_TRUE(std::isfinite(first.loss));
  EXPECT_DOUBLE_EQ(first.lr_backbone, 1e-3);
  EXPECT_EQ(first.terms.size(), 6u);
  // EMA after one step: d·p0 + (1 − d)·p1.
  const auto after = model::state_dict(*trainer.model());
  const std::string name = "encoder.backbone.cls_token";
  ASSERT_TRUE(after.count(name));
  EXPECT_TRUE(at::allclose(trainer.ema().at(name), 0.9 * before.at(name) + 0.1 * after.at(name),
                           1e-6, 1e-7));
  EXPECT_FALSE(at::equal(before.at(name), after.at(name)));
  EXPECT_DOUBLE_EQ(trainer.train_step().lr_backbone, 0.5e-3);  // × 0.5 every step
  EXPECT_EQ(trainer.train_step().stage, 2);
  trainer.train_step();
  std::map<std::string, at::Tensor> stage2;
  for (const auto& [n, t] : model::state_dict(*trainer.model())) stage2[n] = t.clone();
  const StepRecord last = trainer.train_step();
  EXPECT_EQ(last.stage, 3);
  EXPECT_EQ(last.terms.size(), 1u);
  EXPECT_TRUE(trainer.done());
  int changed = 0;
  for (const auto& [n, t] : model::state_dict(*trainer.model())) {
    const bool same = at::equal(t, stage2.at(n));
    if (n.rfind("mask_head.", 0) == 0)
      changed += !same;
    else
      EXPECT_TRUE(same) << n << " changed in stage 3";
  }
  EXPECT_GT(changed, 0);
}

TEST(Trainer, NonFiniteStepsAreSkippedThenStop) {
  json json_config = tiny_config("x");
  json_config["max_nonfinite_steps"] = 2;
  const TrainConfig config = TrainConfig::from_json(json_config);
  model::OmniPointModel network = tiny_model(config);
  {
    at::NoGradGuard no_grad;
    model::state_dict(*network).at("scale_head.0.weight").fill_(NAN);
  }
  Trainer trainer(config, network);
  const StepRecord skipped = trainer.train_step();
  EXPECT_TRUE(skipped.skipped);
  try {
    trainer.train_step();
    FAIL() << "no error after 2 non-finite steps";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("2 steps in a row"), std::string::npos) << e.what();
  }
}

TEST(Trainer, StateRestoresExactlyInMemory) {
  const TrainConfig config = TrainConfig::from_json(tiny_config("x"));
  Trainer straight(config, tiny_model(config));
  for (int i = 0; i < 3; ++i) straight.train_step();
  const StepRecord expected = straight.train_step();

  Trainer first(config, tiny_model(config));
  for (int i = 0; i < 3; ++i) first.train_step();
  Trainer second(config, tiny_model(config));
  second.restore(first.state());
  const StepRecord resumed = second.train_step();
  EXPECT_EQ(resumed.loss, expected.loss);
  for (const auto& [name, t] : model::state_dict(*straight.model()))
    EXPECT_TRUE(at::equal(t, model::state_dict(*second.model()).at(name))) << name;
}

}  // namespace
}  // namespace omnipoint::train
