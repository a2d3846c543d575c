// The training loop on a tiny network and synthetic data: config errors, schedules, stage 3
// freezing, EMA, non-finite step handling, and the exact resume through the CLI.
#include <ATen/ATen.h>
#include <ATen/Context.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <unistd.h>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/train/batch_source.h"
#include "omnipoint/train/checkpoint.h"
#include "omnipoint/train/trainer.h"
#include "support/tiny_omnipoint.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json tiny_model_json() {
  return json::parse(
      test::tiny_omnipoint_config_json("ray_distance", R"({"encoder_dim": 8, "splat_radius": 2})"));
}

json tiny_config(const std::string& output_dir) {
  return {
      {"output_dir", output_dir},
      {"seed", 5},
      {"threads", 1},
      {"model", tiny_model_json()},
      {"data",
       {{"batch_size", 2},
        {"image_size", {28, 28}},
        {"num_tokens", {2, 4}},
        {"datasets",
         {{{"weight", 1},
           {"synth",
            {{"scenes", {"indoor", "outdoor", "object"}},
             {"cameras",
              {"PINHOLE 28 28 20 20 14 14", "OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0"}}}}}}}}},
      {"conditions", {{"probability", 0.9}, {"sparse_ratio", {0.005, 0.01}}}},
      {"loss", {{"local", {{"levels", {4}}, {"patches_per_item", 4}, {"min_points", 8}}}}},
      {"ema", {{"decay", 0.9}}},
      {"stages",
       {{{"stage", 1}, {"steps", 2}, {"lr_backbone", 1e-3}, {"lr_heads", 1e-3}, {"decay_every", 1}},
        {{"stage", 2}, {"steps", 2}, {"lr_backbone", 5e-4}, {"lr_heads", 5e-4}},
        {{"stage", 3}, {"steps", 1}, {"lr_backbone", 0}, {"lr_heads", 1e-3}}}},
      {"checkpoint_every", 0},
      {"log_every", 1}};
}

model::OmniPointModel tiny_model(const TrainConfig& config) {
  at::manual_seed(11);
  return build_model(config);
}

std::string temp_dir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("omnipoint_train_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

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

TEST(BatchSource, BatchesAreAFunctionOfSeedStepAndRank) {
  const TrainConfig config = TrainConfig::from_json(tiny_config("x"));
  const BatchSource source(config);
  const TrainingBatch a = source.batch(3, true), b = source.batch(3, true);
  EXPECT_TRUE(at::equal(a.image, b.image));
  EXPECT_TRUE(at::equal(a.condition_sparse_depth, b.condition_sparse_depth));
  EXPECT_EQ(a.num_tokens, b.num_tokens);
  EXPECT_EQ(a.image.sizes(), (std::vector<int64_t>{2, 3, 28, 28}));
  EXPECT_FALSE(at::equal(a.image, source.batch(4, true).image));
  // Two ranks of batch 1 read the two halves of the global batch of 2 (world size 2 → items
  // 2s·1 + r ... the same indices as one process with batch 2).
  TrainConfig half = config;
  half.batch_size = 1;
  const BatchSource half_source(half);
  EXPECT_TRUE(at::equal(half_source.batch(3, true, 0, 2).image[0], a.image[0]));
  EXPECT_TRUE(at::equal(half_source.batch(3, true, 1, 2).image[0], a.image[1]));
  // Without conditions nothing is passed; sparse depth is sampled from the GT distances.
  EXPECT_EQ(source.batch(3, false).condition_rays.abs().sum().item<double>(), 0.0);
  const at::Tensor sparse = a.condition_sparse_depth, has = sparse > 0;
  if (has.any().item<bool>()) {
    EXPECT_TRUE(at::equal(sparse.masked_select(has), a.targets.distance.masked_select(has)));
  }
}

TEST(BatchSource, ThreadsTakeWholeItemsAndTheBatchIsTheSame) {
  // A batch of 5 with P2A and photometric augmentation on: with 2 threads each thread makes
  // whole items, and the batch equals the one made on one thread bit for bit.
  json json_config = tiny_config("x");
  json_config["data"]["batch_size"] = 5;
  json_config["augment"] = {{"p2a", true}, {"p2a_probability", 0.5}, {"photometric", true}};
  const BatchSource source(TrainConfig::from_json(json_config));
  const int threads = at::get_num_threads();
  at::set_num_threads(1);
  const TrainingBatch one = source.batch(7, true);
  at::set_num_threads(2);
  const TrainingBatch two = source.batch(7, true);
  at::set_num_threads(threads);
  EXPECT_TRUE(at::equal(one.image, two.image));
  EXPECT_TRUE(at::equal(one.condition_rays, two.condition_rays));
  EXPECT_TRUE(at::equal(one.condition_sparse_depth, two.condition_sparse_depth));
  EXPECT_TRUE(at::equal(one.targets.rays, two.targets.rays));
  EXPECT_TRUE(at::equal(one.targets.distance, two.targets.distance));
  EXPECT_TRUE(at::equal(one.targets.mask, two.targets.mask));
  EXPECT_TRUE(at::equal(one.targets.mask_negative, two.targets.mask_negative));
  EXPECT_TRUE(at::equal(one.targets.metric, two.targets.metric));
  EXPECT_EQ(one.num_tokens, two.num_tokens);
  // The items differ from each other (each drew its own scene).
  EXPECT_FALSE(at::equal(one.image[0], one.image[1]));
}

// One camera for every item, augmentations as given.
json single_camera_config(const std::string& spec, const json& augment) {
  json config = tiny_config("x");
  config["data"]["datasets"][0]["synth"]["cameras"] = {spec};
  config["augment"] = augment;
  return config;
}

TEST(BatchSource, P2ARendersPerspectiveItemsIntoWideCamerasFromStageTwo) {
  const std::string pinhole = "PINHOLE 28 28 20 20 14 14";
  const TrainConfig config = TrainConfig::from_json(
      single_camera_config(pinhole, {{"p2a", true}, {"p2a_probability", 1.0}}));
  const BatchSource source(config);
  const at::Tensor pinhole_rays = camera::parse_camera(pinhole).ray_map(at::kFloat).rays;
  // Stage 1 (no conditions): the items as the data gives them.
  const TrainingBatch plain = source.batch(2, false);
  for (int64_t k = 0; k < 2; ++k) EXPECT_TRUE(at::equal(plain.targets.rays[k], pinhole_rays));
  EXPECT_TRUE(at::equal(plain.targets.mask_negative, plain.targets.mask.logical_not()));
  // Stage 2: every item seen through a virtual fisheye or panorama, deterministically.
  const TrainingBatch augmented = source.batch(2, true), again = source.batch(2, true);
  EXPECT_TRUE(at::equal(augmented.image, again.image));
  EXPECT_TRUE(at::equal(augmented.targets.distance, again.targets.distance));
  for (int64_t k = 0; k < 2; ++k) {
    const at::Tensor rays = augmented.targets.rays[k];
    EXPECT_FALSE(at::allclose(rays, pinhole_rays)) << "item " << k << " kept the pinhole";
    // A wide camera: some rays look more than 60° off the axis (the pinhole's reach ~35°).
    EXPECT_LT(rays.select(-1, 2).min().item<double>(), 0.5) << "item " << k;
    const at::Tensor mask = augmented.targets.mask[k];
    EXPECT_GT(mask.sum().item<int64_t>(), 0) << "item " << k;
    EXPECT_LT(mask.sum().item<int64_t>(), mask.numel())
        << "item " << k;  // beyond the source frustum
    EXPECT_TRUE((augmented.targets.distance[k].masked_select(mask) > 0).all().item<bool>());
  }
  // Unlabelled pixels of a rendered view are unknown, not sky.
  EXPECT_FALSE(augmented.targets.mask_negative.any().item<bool>());
}

TEST(BatchSource, A2PReplacesWideLabelsWithTheTeachersStitchedPrediction) {
  const std::string dir = temp_dir("a2p_teacher");
  const std::string teacher_path = dir + "/teacher.safetensors";
  const TrainConfig base = TrainConfig::from_json(tiny_config("x"));
  const model::OmniPointModel teacher = tiny_model(base);
  io::write_safetensors(teacher_path, model::state_dict(*teacher),
                        model::omnipoint_metadata(teacher->config()));

  const std::string fisheye = "OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0";
  const json augment = {{"a2p", true}, {"a2p_teacher", teacher_path}, {"a2p_teacher_tokens", 4}};
  const BatchSource source(TrainConfig::from_json(single_camera_config(fisheye, augment)));
  const TrainingBatch plain = source.batch(1, false), pseudo = source.batch(1, true);
  EXPECT_TRUE(at::equal(plain.image, pseudo.image));  // the image itself is kept
  EXPECT_TRUE(plain.targets.metric.all().item<bool>());
  EXPECT_FALSE(pseudo.targets.metric.any().item<bool>());  // pseudo-labels are not metric
  EXPECT_FALSE(pseudo.targets.mask_negative.any().item<bool>());
  const at::Tensor mask = pseudo.targets.mask;
  EXPECT_GT(mask.sum().item<int64_t>(), 0);
  EXPECT_LT(mask.sum().item<int64_t>(),
            plain.targets.rays.select(-1, 2).ne(0).sum().item<int64_t>());
  EXPECT_TRUE((pseudo.targets.distance.masked_select(mask) > 0).all().item<bool>());
  // The labels are the teacher's, not the ground truth.
  EXPECT_FALSE(at::allclose(pseudo.targets.distance.masked_select(mask),
                            plain.targets.distance.masked_select(mask)));
  // The sparse-depth condition comes from the pseudo-labels.
  const at::Tensor sparse = pseudo.condition_sparse_depth, has = sparse > 0;
  EXPECT_TRUE(at::equal(sparse.masked_select(has), pseudo.targets.distance.masked_select(has)));

  // A teacher that cannot be read is named.
  json missing = augment;
  missing["a2p_teacher"] = dir + "/none.safetensors";
  try {
    BatchSource bad(TrainConfig::from_json(single_camera_config(fisheye, missing)));
    FAIL() << "a missing teacher was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("A2P teacher"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// Sources of two image sizes are two aspect buckets: one size per step, the same on every
// rank, both drawn by weight; an evaluation batch can ask for a bucket.
TEST(BatchSource, AspectBucketsGiveOneSizePerStepOnEveryRank) {
  json config = tiny_config("x");
  config["data"]["datasets"] = {
      {{"weight", 1},
       {"synth", {{"scenes", {"indoor"}}, {"cameras", {"PINHOLE 28 21 20 20 14 10.5"}}}}},
      {{"weight", 1},
       {"image_size", {28, 14}},
       {"synth", {{"scenes", {"outdoor"}}, {"cameras", {"EQUIRECTANGULAR 28 14"}}}}}};
  config["data"]["image_size"] = {28, 21};
  const BatchSource source(TrainConfig::from_json(config));
  EXPECT_EQ(source.bucket_count(), 2);
  int wide = 0, steps = 0;
  for (int64_t step = 0; step < 24; ++step, ++steps) {
    const TrainingBatch rank0 = source.batch(step, false, 0, 2),
                        rank1 = source.batch(step, false, 1, 2);
    EXPECT_EQ(rank0.image.sizes(), rank1.image.sizes()) << "step " << step;
    const int64_t width = rank0.image.size(3), height = rank0.image.size(2);
    ASSERT_TRUE((width == 28 && height == 21) || (width == 28 && height == 14))
        << width << "x" << height;
    if (height == 14) {
      ++wide;
      // The 2:1 bucket holds the panorama source alone: its rays cover the whole sphere.
      EXPECT_LT(rank0.targets.rays.select(-1, 2).min().item<double>(), -0.9);
    }
  }
  EXPECT_GT(wide, 4);
  EXPECT_LT(wide, steps - 4);
  EXPECT_EQ(source.batch(0, false, 0, 1, 1, 0).image.size(2), 21);
  EXPECT_EQ(source.batch(0, false, 0, 1, 1, 1).image.size(2), 14);
  EXPECT_EQ(source.batch(0, false, 0, 1, 1, 3).image.size(2), 14);  // modulo the bucket count
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

// A mirrored item is the mirror image of the same item: image, labels and rays (x negated).
TEST(BatchSource, FlipMirrorsImageLabelsAndRays) {
  json config = tiny_config("x");
  const BatchSource plain(TrainConfig::from_json(config));
  config["augment"] = {{"flip", true}};
  const BatchSource flipping(TrainConfig::from_json(config));
  int mirrored = 0, kept = 0;
  for (int64_t step = 0; step < 6; ++step) {
    const TrainingBatch a = plain.batch(step, true), b = flipping.batch(step, true);
    for (int64_t k = 0; k < a.image.size(0); ++k) {
      if (at::equal(a.image[k], b.image[k])) {
        ++kept;
        EXPECT_TRUE(at::equal(a.targets.rays[k], b.targets.rays[k]));
        continue;
      }
      ++mirrored;
      EXPECT_TRUE(at::equal(a.image[k].flip({2}), b.image[k]));
      EXPECT_TRUE(at::equal(a.targets.distance[k].flip({1}), b.targets.distance[k]));
      EXPECT_TRUE(at::equal(a.targets.mask[k].flip({1}), b.targets.mask[k]));
      EXPECT_TRUE(at::equal(a.targets.mask_negative[k].flip({1}), b.targets.mask_negative[k]));
      const at::Tensor rays = a.targets.rays[k].flip({1});
      EXPECT_TRUE(at::equal(rays.select(-1, 0).neg(), b.targets.rays[k].select(-1, 0)));
      EXPECT_TRUE(at::equal(rays.narrow(-1, 1, 2), b.targets.rays[k].narrow(-1, 1, 2)));
      // The ray condition is the mirrored rays too, where it is on.
      if (b.condition_rays[k].abs().sum().item<double>() > 0) {
        EXPECT_TRUE(at::equal(b.condition_rays[k], b.targets.rays[k].permute({2, 0, 1})));
      }
    }
  }
  EXPECT_GT(mirrored, 0);
  EXPECT_GT(kept, 0);
}

// Items of an unlabelled source never train stage 1 and are always A2P's from stage 2.
TEST(BatchSource, UnlabelledSourcesEnterOnlyThroughA2P) {
  const std::string dir = temp_dir("unlabelled");
  const std::string teacher_path = dir + "/teacher.safetensors";
  const model::OmniPointModel teacher = tiny_model(TrainConfig::from_json(tiny_config("x")));
  io::write_safetensors(teacher_path, model::state_dict(*teacher),
                        model::omnipoint_metadata(teacher->config()));
  json config = tiny_config("x");
  config["data"]["datasets"] = {
      {{"weight", 1},
       {"synth", {{"scenes", {"indoor"}}, {"cameras", {"PINHOLE 28 28 20 20 14 14"}}}}},
      {{"weight", 3},
       {"labels", false},
       {"synth",
        {{"scenes", {"indoor"}}, {"cameras", {"OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0"}}}}}};
  config["augment"] = {{"a2p", true},
                       {"a2p_probability", 0},
                       {"a2p_teacher", teacher_path},
                       {"a2p_teacher_tokens", 4}};
  const BatchSource source(TrainConfig::from_json(config));
  const at::Tensor pinhole_rays =
      camera::parse_camera("PINHOLE 28 28 20 20 14 14").ray_map(at::kFloat).rays;
  int wide = 0;
  for (int64_t step = 0; step < 4; ++step) {
    const TrainingBatch stage1 = source.batch(step, false), stage2 = source.batch(step, true);
    for (int64_t k = 0; k < 2; ++k) {
      EXPECT_TRUE(at::equal(stage1.targets.rays[k], pinhole_rays)) << "stage 1 saw a fisheye";
      if (at::equal(stage2.targets.rays[k], pinhole_rays)) {
        EXPECT_TRUE(stage2.targets.metric[k].item<bool>());  // labelled: exact, metric
        continue;
      }
      ++wide;  // unlabelled: pseudo-labelled, not metric, no sky negatives
      EXPECT_FALSE(stage2.targets.metric[k].item<bool>());
      EXPECT_FALSE(stage2.targets.mask_negative[k].any().item<bool>());
    }
  }
  EXPECT_GT(wide, 0);
  fs::remove_all(dir);
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

// The conditioning ablations fine-tune one stage-1 model with other condition settings.
TEST(BuildModel, OmniPointInitCanChangeOnlyTheConditioning) {
  const std::string dir = temp_dir("init_conditioning");
  const TrainConfig base = TrainConfig::from_json(tiny_config("x"));
  const model::OmniPointModel source = tiny_model(base);
  const std::string path = dir + "/stage1.safetensors";
  io::write_safetensors(path, model::state_dict(*source),
                        model::omnipoint_metadata(source->config()));

  json config = tiny_config(dir);
  config.erase("model");
  config["init"] = {{"from", "omnipoint"}, {"path", path}};
  config["model"] = {{"conditioning",
                      {{"encoder_dim", 8},
                       {"splat_radius", 2},
                       {"state_embeddings", false},
                       {"gaussian_smoothing", false}}},
                     {"num_tokens_range", {3, 4}}};
  const model::OmniPointModel changed = build_model(TrainConfig::from_json(config));
  EXPECT_EQ(changed->config().num_tokens_range, (std::array<int64_t, 2>{3, 4}));
  EXPECT_FALSE(changed->config().conditioning.state_embeddings);
  EXPECT_FALSE(changed->config().conditioning.gaussian_smoothing);
  const auto before = model::state_dict(*source), after = model::state_dict(*changed);
  EXPECT_LT(after.size(), before.size());  // the state embeddings are gone
  for (const auto& [name, tensor] : after) {
    ASSERT_TRUE(before.count(name)) << name;
    EXPECT_TRUE(at::equal(tensor, before.at(name))) << name;
  }
  // Anything but the conditioning and the token budget is the file's, not the config's.
  config["model"]["encoder"] = tiny_model_json()["encoder"];
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
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

std::map<int64_t, double> losses_by_step(const std::string& log) {
  std::map<int64_t, double> losses;
  std::istringstream lines(io::read_file(log));
  std::string line;
  while (std::getline(lines, line)) {
    const json record = json::parse(line);
    if (record.contains("loss"))
      losses[record.at("step").get<int64_t>()] = record.at("loss").get<double>();
  }
  return losses;
}

int run_cli(const std::string& arguments) {
  return std::system((std::string(OMNIPOINT_CLI) + " train " + arguments + " 2>/dev/null").c_str());
}

TEST(TrainCli, ResumedRunEqualsUninterruptedRun) {
  const std::string root = temp_dir("resume");
  // Stage 2 with P2A and A2P: the teacher's pseudo-labels must resume exactly too.
  const model::OmniPointModel teacher = tiny_model(TrainConfig::from_json(tiny_config("x")));
  io::write_safetensors(root + "/teacher.safetensors", model::state_dict(*teacher),
                        model::omnipoint_metadata(teacher->config()));
  const auto write_config = [&](const std::string& name) {
    json config = tiny_config(root + "/" + name);
    config["checkpoint_every"] = 2;
    config["augment"] = {{"p2a", true},
                         {"p2a_probability", 0.5},
                         {"a2p", true},
                         {"a2p_teacher", root + "/teacher.safetensors"}};
    const std::string path = root + "/" + name + ".json";
    std::ofstream(path) << config.dump(2);
    return path;
  };
  const std::string straight = write_config("straight"), interrupted = write_config("interrupted");
  ASSERT_EQ(run_cli("--config " + straight), 0);
  // Stopped after step 3 (mid stage 2), and as if killed before its checkpoint: `latest`
  // still names step 2, so the resumed run redoes step 3 and rewrites its log record.
  ASSERT_EQ(run_cli("--config " + interrupted + " --stop-after 3"), 0);
  EXPECT_FALSE(fs::exists(root + "/interrupted/model.safetensors"));
  ASSERT_TRUE(fs::exists(root + "/interrupted/checkpoints/step_00000003"));
  std::ofstream(root + "/interrupted/checkpoints/latest") << "step_00000002\n";
  ASSERT_EQ(run_cli("--config " + interrupted + " --resume " + root + "/interrupted"), 0);

  const auto expected = losses_by_step(root + "/straight/log.jsonl");
  const auto resumed = losses_by_step(root + "/interrupted/log.jsonl");
  ASSERT_EQ(expected.size(), 5u);
  EXPECT_EQ(resumed, expected);
  for (const std::string file : {"model.safetensors", "model_ema.safetensors"}) {
    const auto a = io::read_safetensors(root + "/straight/" + file, std::nullopt).tensors;
    const auto b = io::read_safetensors(root + "/interrupted/" + file, std::nullopt).tensors;
    ASSERT_EQ(a.size(), b.size());
    for (const auto& [name, t] : a) EXPECT_TRUE(at::equal(t, b.at(name))) << file << " " << name;
  }
  // Resuming from a checkpoint's step folder works too; a bad path is one clear error.
  EXPECT_NO_THROW(read_checkpoint(root + "/interrupted/checkpoints/step_00000005"));
  EXPECT_THROW(read_checkpoint(root + "/nothing"), std::runtime_error);
  EXPECT_NE(run_cli("--config " + interrupted + " --resume " + root + "/nothing"), 0);
  fs::remove_all(root);
}

// A real SIGKILL at an arbitrary moment (mid-step, mid-log line or mid-checkpoint): the resumed
// run ends with the uninterrupted run's weights and loss curve.
TEST(TrainCli, KilledRunResumesToTheSameWeights) {
  const std::string root = temp_dir("kill");
  const auto write_config = [&](const std::string& name) {
    json config = tiny_config(root + "/" + name);
    config["stages"][0]["steps"] = 30;
    config["stages"][1]["steps"] = 30;
    config["checkpoint_every"] = 4;
    std::ofstream(root + "/" + name + ".json") << config.dump(2);
    return root + "/" + name + ".json";
  };
  const std::string straight = write_config("straight"), killed = write_config("killed");
  ASSERT_EQ(run_cli("--config " + straight), 0);
  // Kill after a growing delay until a checkpoint exists and the run had not finished.
  bool interrupted = false;
  for (const char* delay : {"1", "2", "4", "8"}) {
    fs::remove_all(root + "/killed");
    std::system(("timeout -s KILL " + std::string(delay) + " " + OMNIPOINT_CLI +
                 " train --config " + killed + " 2>/dev/null")
                    .c_str());
    interrupted = fs::exists(root + "/killed/checkpoints/latest") &&
                  !fs::exists(root + "/killed/model.safetensors");
    if (interrupted) break;
  }
  ASSERT_TRUE(interrupted) << "no delay killed the run between its first checkpoint and its end";
  ASSERT_EQ(run_cli("--config " + killed + " --resume " + root + "/killed"), 0);
  EXPECT_EQ(losses_by_step(root + "/killed/log.jsonl"),
            losses_by_step(root + "/straight/log.jsonl"));
  for (const std::string file : {"model.safetensors", "model_ema.safetensors"}) {
    const auto a = io::read_safetensors(root + "/straight/" + file, std::nullopt).tensors;
    const auto b = io::read_safetensors(root + "/killed/" + file, std::nullopt).tensors;
    ASSERT_EQ(a.size(), b.size());
    for (const auto& [name, t] : a) EXPECT_TRUE(at::equal(t, b.at(name))) << file << " " << name;
  }
  fs::remove_all(root);
}

TEST(TrainCli, LogsBenchmarkScoresAndDrawsCurves) {
  const std::string root = temp_dir("curves");
  json config = tiny_config(root + "/run");
  config["eval_every"] = 2;
  config["eval_batches"] = 1;
  std::ofstream(root + "/run.json") << config.dump(2);
  ASSERT_EQ(run_cli("--config " + root + "/run.json"), 0);
  int evaluations = 0;
  std::istringstream lines(io::read_file(root + "/run/log.jsonl"));
  for (std::string line; std::getline(lines, line);) {
    const json record = json::parse(line);
    if (!record.contains("eval")) continue;
    ++evaluations;
    const double delta1 = record["eval"].at("points_delta1").get<double>();
    EXPECT_GE(delta1, 0.0);
    EXPECT_LE(delta1, 1.0);
    EXPECT_GT(record["eval"].at("points_rel").get<double>(), 0.0);
  }
  EXPECT_EQ(evaluations, 2);  // steps 2 and 4 of 5
  if (io::image_io_available()) {
    const at::Tensor curves = io::read_image(root + "/run/curves.png");
    EXPECT_EQ(curves.size(1), 1200);
  }
  fs::remove_all(root);
}

TEST(TrainCli, TwoGlooRanksEqualOneProcessOnTheCombinedBatch) {
  const std::string root = temp_dir("ddp");
  const auto write_config = [&](const std::string& name, int64_t batch_size) {
    json config = tiny_config(root + "/" + name);
    config["data"]["batch_size"] = batch_size;
    // The local loss draws its anchors per process; off here so that the objective is the same.
    config["loss"]["weights"] = {{"local", 0}};
    // The all-reduce sums in another order than autograd over the whole batch (float rounding,
    // ~1e-7 relative). With Adam's eps ~ 0 the first update is lr·sign(g), which turns that
    // rounding into ±lr for the gradients that are ~0; eps = 1 keeps the update proportional to
    // the gradient, so the comparison measures the gradients the ranks agree on.
    config["optimizer"] = {{"eps", 1.0}};
    const std::string path = root + "/" + name + ".json";
    std::ofstream(path) << config.dump(2);
    return path;
  };
  const std::string single = write_config("single", 2), ranks = write_config("ranks", 1);
  ASSERT_EQ(run_cli("--config " + single), 0);
  const std::string port = std::to_string(20000 + ::getpid() % 20000);
  ASSERT_EQ(std::system(("MASTER_PORT=" + port + " " + std::string(OMNIPOINT_CLI) +
                         " train --config " + ranks + " --nproc 2 2>/dev/null")
                            .c_str()),
            0);
  const auto a = io::read_safetensors(root + "/single/model.safetensors", std::nullopt).tensors;
  const auto b = io::read_safetensors(root + "/ranks/model.safetensors", std::nullopt).tensors;
  ASSERT_EQ(a.size(), b.size());
  double worst = 0;
  for (const auto& [name, t] : a)
    worst = std::max(worst, (t - b.at(name)).abs().max().item<double>());
  EXPECT_LE(worst, 1e-6);
  // Only rank 0 wrote the log: one record per step.
  EXPECT_EQ(losses_by_step(root + "/ranks/log.jsonl").size(), 5u);
  fs::remove_all(root);
}

}  // namespace
}  // namespace omnipoint::train
