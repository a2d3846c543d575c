// Training batches: a pure function of (seed, step, rank) whatever the thread count or
// prefetching, aspect buckets, P2A/A2P, mirroring, unlabelled sources, and bad samples skipped
// and counted.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/train/batch_source.h"
#include "support/thread_count.h"
#include "train/tiny_training.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

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

// The batches equal one another tensor for tensor.
void expect_equal(const TrainingBatch& a, const TrainingBatch& b, const std::string& what) {
  EXPECT_TRUE(at::equal(a.image, b.image)) << what;
  EXPECT_TRUE(at::equal(a.condition_rays, b.condition_rays)) << what;
  EXPECT_TRUE(at::equal(a.condition_sparse_depth, b.condition_sparse_depth)) << what;
  EXPECT_TRUE(at::equal(a.targets.rays, b.targets.rays)) << what;
  EXPECT_TRUE(at::equal(a.targets.distance, b.targets.distance)) << what;
  EXPECT_TRUE(at::equal(a.targets.mask, b.targets.mask)) << what;
  EXPECT_TRUE(at::equal(a.targets.mask_negative, b.targets.mask_negative)) << what;
  EXPECT_TRUE(at::equal(a.targets.metric, b.targets.metric)) << what;
  EXPECT_EQ(a.num_tokens, b.num_tokens) << what;
}

// A folder of `good` synthetic sample folders s0, s1, ... (PINHOLE 48x36) followed by `bad`
// ones whose distances hold a NaN.
std::string sample_folders(const std::string& root, int good, int bad) {
  fs::remove_all(root);
  const camera::Camera camera = camera::parse_camera("PINHOLE 48 36 40 40 24 18");
  for (int i = 0; i < good + bad; ++i) {
    const std::string folder = root + "/s" + std::to_string(i);
    const data::synth::SynthSample rendered =
        data::synth::synthesize(data::synth::SceneKind::kObject, static_cast<uint64_t>(i), camera);
    data::write_sample(folder, rendered.sample);
    if (i >= good) {
      at::Tensor distance = rendered.sample.distance.clone();
      distance[0][0] = NAN;
      io::write_npy(folder + "/distance.npy", distance);
    }
  }
  return root;
}

// A config reading `folders` alone (weight `weight`), or beside the tiny config's synthetic
// source when `with_synth`.
json folder_config(const std::string& folders, bool with_synth = false) {
  json config = tiny_config("x");
  const json source = {{"weight", 3}, {"folders", folders}};
  if (with_synth)
    config["data"]["datasets"].push_back(source);
  else
    config["data"]["datasets"] = json::array({source});  // {source} alone is a copy on clang
  return config;
}

// Prefetched batches are the batches: made on the background thread, taken by the matching
// batch(), whatever the thread count; a prefetch nobody takes is dropped.
TEST(BatchSource, PrefetchedBatchesAreTheBatchesWhateverTheThreadCount) {
  json json_config = tiny_config("x");
  json_config["data"]["batch_size"] = 3;
  json_config["augment"] = {{"p2a", true}, {"p2a_probability", 0.5}, {"photometric", true}};
  const TrainConfig config = TrainConfig::from_json(json_config);
  const BatchSource direct(config);
  std::vector<TrainingBatch> expected;
  for (int64_t step = 0; step < 4; ++step) expected.push_back(direct.batch(step, step >= 2));
  for (const int threads : {1, 2}) {
    const test::ThreadCount thread_count(threads);
    const BatchSource prefetching(config);
    prefetching.prefetch(0, false);
    for (int64_t step = 0; step < 4; ++step) {
      if (step + 1 < 4) {
        const TrainingBatch batch = prefetching.batch(step, step >= 2);
        prefetching.prefetch(step + 1, step + 1 >= 2);
        expect_equal(batch, expected[static_cast<size_t>(step)],
                     "step " + std::to_string(step) + ", " + std::to_string(threads) + " threads");
      } else {
        // Another batch (an evaluation's) between a prefetch and its step.
        expect_equal(prefetching.batch(0, true, 0, 1, 1, 0), direct.batch(0, true, 0, 1, 1, 0),
                     "evaluation batch");
        expect_equal(prefetching.batch(step, true), expected[static_cast<size_t>(step)],
                     "last step");
      }
    }
    // A prefetch of other arguments is replaced, and one never taken stops with the source.
    prefetching.prefetch(7, true);
    prefetching.prefetch(8, true);
    expect_equal(prefetching.batch(8, true), direct.batch(8, true), "replaced prefetch");
    prefetching.prefetch(9, true);
  }
}

// Every bad sample is skipped, warned about once and counted by reason; the items draw good
// samples in their place, the same ones whether the bad samples were met before or not.
TEST(BatchSource, BadSamplesAreSkippedCountedAndReplacedDeterministically) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const std::string root = temp_dir("bad_samples");
  const std::string folders = sample_folders(root + "/samples", 1, 2);
  const TrainConfig config = TrainConfig::from_json(folder_config(folders));
  BatchSource source(config);
  // The one good sample, as an item of the 28x28 bucket (stage 1: no augmentation).
  const data::Sample good = data::fit_sample(data::read_sample(folders + "/s0"), 28, 28);
  const at::Tensor good_image = good.image.permute({2, 0, 1});
  std::vector<TrainingBatch> batches;
  for (int64_t step = 0; step < 4; ++step) {
    batches.push_back(source.batch(step, false));
    for (int64_t k = 0; k < 2; ++k)
      EXPECT_TRUE(at::equal(batches.back().image[k], good_image))
          << "step " << step << " item " << k;
  }
  int64_t nan = 0;
  for (const auto& [reason, count] : source.skipped_samples()) {
    EXPECT_EQ(reason.find(folders), std::string::npos) << "the reason names the sample: " << reason;
    if (reason.find("NaN") != std::string::npos) nan += count;
  }
  EXPECT_GE(nan, 2);  // 8 draws of 3 samples, two of them bad
  const std::vector<std::string> warnings = source.take_warnings();
  EXPECT_EQ(warnings.size(), 2u);  // once per bad sample
  for (const std::string& warning : warnings)
    EXPECT_NE(warning.find("NaN"), std::string::npos) << warning;
  EXPECT_TRUE(source.take_warnings().empty());
  // A fresh source (nothing met yet) on two threads, prefetching, gives the same batches.
  const test::ThreadCount two(2);
  const BatchSource fresh(config);
  fresh.prefetch(0, false);
  for (int64_t step = 0; step < 4; ++step) {
    expect_equal(fresh.batch(step, false), batches[static_cast<size_t>(step)],
                 "step " + std::to_string(step));
    fresh.prefetch(step + 1, false);
  }
  fs::remove_all(root);
}

// A source of which no sample can be read is one clear error, from batch() (also through a
// prefetch); a missing or empty directory already from the constructor.
TEST(BatchSource, SourcesWithoutUsableSamplesAreErrors) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const std::string root = temp_dir("no_usable");
  const std::string only_bad = sample_folders(root + "/bad", 0, 2);
  const BatchSource source(TrainConfig::from_json(folder_config(only_bad)));
  const auto expect_error = [&](const std::function<void()>& make) {
    try {
      make();
      FAIL() << "a batch of bad samples";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("no usable sample"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(only_bad), std::string::npos) << e.what();
    }
  };
  expect_error([&] { source.batch(0, false); });
  source.prefetch(1, false);
  expect_error([&] { source.batch(1, false); });

  fs::create_directories(root + "/empty");
  EXPECT_THROW(BatchSource(TrainConfig::from_json(folder_config(root + "/empty"))),
               std::runtime_error);
  EXPECT_THROW(BatchSource(TrainConfig::from_json(folder_config(root + "/missing"))),
               std::runtime_error);
  json no_camera = tiny_config("x");
  no_camera["data"]["datasets"][0]["synth"]["cameras"] = json::array();
  EXPECT_THROW(TrainConfig::from_json(no_camera), std::invalid_argument);
  fs::remove_all(root);
}

// Unlabelled sample folders (the "images" format's, "labelled": false) in a source that says
// "labels": true: one clear error naming the source, not an item trained on zero labels.
TEST(BatchSource, UnlabelledSamplesInALabelledSourceAreAnError) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const std::string root = temp_dir("unlabelled_samples");
  const std::string folders = sample_folders(root + "/samples", 2, 0);
  for (const std::string name : {"s0", "s1"}) {
    data::Sample sample = data::read_sample(folders + "/" + name);
    sample.distance = at::zeros_like(sample.distance);
    sample.mask = at::zeros_like(sample.mask);
    sample.metric = false;
    sample.labelled = false;
    fs::remove_all(folders + "/" + name);
    data::write_sample(folders + "/" + name, sample);
  }
  const BatchSource source(TrainConfig::from_json(folder_config(folders)));
  try {
    source.batch(0, false);
    FAIL() << "a labelled batch from unlabelled samples";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(folders), std::string::npos) << e.what();
    EXPECT_NE(
        std::string(e.what()).find("its samples have no labels; declare it \"labels\": false"),
        std::string::npos)
        << e.what();
  }
  fs::remove_all(root);
}

// Folder samples and synthetic ones mixed by weight in one bucket: every item has the bucket's
// size, its camera's rays, distances only where labelled and positive there, metric labels.
TEST(BatchSource, FolderAndSyntheticItemsMixWithConsistentLabels) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const std::string root = temp_dir("mix");
  const std::string folders = sample_folders(root + "/samples", 3, 0);
  json config = folder_config(folders, /*with_synth=*/true);
  config["data"]["datasets"][0]["synth"]["cameras"] = {"OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0"};
  const BatchSource source(TrainConfig::from_json(config));
  const at::Tensor fisheye_rays =
      camera::parse_camera("OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0").ray_map(at::kFloat).rays;
  const at::Tensor folder_rays =
      data::fit_sample(data::read_sample(folders + "/s0"), 28, 28).camera.ray_map(at::kFloat).rays;
  int from_synth = 0, from_folders = 0;
  for (int64_t step = 0; step < 8; ++step) {
    const TrainingBatch b = source.batch(step, false);
    ASSERT_EQ(b.image.sizes(), (at::IntArrayRef{2, 3, 28, 28}));
    EXPECT_EQ(b.targets.rays.sizes(), (at::IntArrayRef{2, 28, 28, 3}));
    EXPECT_GE(b.image.min().item<double>(), 0.0);
    EXPECT_LE(b.image.max().item<double>(), 1.0);
    const at::Tensor mask = b.targets.mask;
    EXPECT_EQ(b.targets.distance.masked_select(mask.logical_not()).abs().sum().item<double>(), 0.0);
    EXPECT_GT(b.targets.distance.masked_select(mask).min().item<double>(), 0.0);
    EXPECT_TRUE(b.targets.metric.all().item<bool>());
    for (int64_t k = 0; k < 2; ++k) {
      if (at::equal(b.targets.rays[k], fisheye_rays)) {
        ++from_synth;
      } else {
        EXPECT_TRUE(at::equal(b.targets.rays[k], folder_rays)) << "step " << step << " item " << k;
        ++from_folders;
      }
    }
  }
  EXPECT_GT(from_synth, 0);
  EXPECT_GT(from_folders, 0);
  fs::remove_all(root);
}

}  // namespace
}  // namespace omnipoint::train
