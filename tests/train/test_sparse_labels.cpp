// Learning from sparse LiDAR labels end to end: a synthetic drive written in the KITTI raw layout
// (data/synth/kitti_raw_drive.h) reads back through the "kitti-raw" reader onto the scene's
// surfaces, a training config names it as a native source, its items train with the sparse
// rules (no sky negatives, conditions drawn from the labels), and fine-tuning on its training
// frames lowers the error on its held-out frames.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/synth/kitti_raw_drive.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/train/batch_source.h"
#include "omnipoint/train/trainer.h"
#include "support/cli_run.h"
#include "support/scratch_dir.h"
#include "tiny_training.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const char* const kCamera = "PINHOLE 96 32 56 56 48 16";  // KITTI's field of view, 3:1

data::synth::KittiRawDriveOptions drive_options(int64_t frames, int64_t held_out) {
  data::synth::KittiRawDriveOptions options;
  options.camera = camera::parse_camera(kCamera);
  options.scene = data::synth::SceneKind::kOutdoor;
  options.seed = 300;
  options.frames = frames;
  options.held_out = held_out;
  // 8 rings 30/7° apart (4 pixels here), a firing every 2°: about 10 % of these small frames.
  options.lidar.beams = 8;
  options.lidar.min_elevation_deg = -15;
  options.lidar.max_elevation_deg = 15;
  options.lidar.azimuth_steps = 180;
  options.synth.render.shadows = false;
  options.synth.render.ambient_occlusion = false;
  return options;
}

// A sweep file: (N, 4) float32 x, y, z, reflectance.
at::Tensor read_sweep(const fs::path& path) {
  const std::string bytes = io::read_file(path.string());
  const int64_t n = static_cast<int64_t>(bytes.size() / (4 * sizeof(float)));
  return at::from_blob(const_cast<char*>(bytes.data()), {n, 4}, at::kFloat).clone();
}

TEST(SparseLabels, SyntheticDriveReadsBackOntoTheScenesSurfaces) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path dir = test::fresh_process_dir("omnipoint_synth_drive");
  const fs::path root = dir / "drive";
  const data::synth::KittiRawDriveOptions options = drive_options(2, 1);
  const data::synth::KittiRawDriveSummary summary =
      data::synth::write_kitti_raw_drive(root.string(), options);
  const std::string date = data::synth::kSynthDriveDate;
  const std::string train_drive = date + "/" + date + "_drive_0001_sync";
  EXPECT_EQ(summary.train_frames,
            (std::vector<std::string>{train_drive + " 0 l", train_drive + " 1 l"}));
  EXPECT_EQ(summary.test_frames,
            (std::vector<std::string>{date + "/" + date + "_drive_0002_sync 0 l"}));
  EXPECT_EQ(test::slurp(root / "train_files.txt"), train_drive + " 0 l\n" + train_drive + " 1 l\n");

  // The sweep of the first frame: points on the beams' rings, at the distances of the scene's
  // surfaces along their directions (cast again from the camera: the sensor sits there).
  const at::Tensor sweep =
      read_sweep(root / train_drive / "velodyne_points" / "data" / "0000000000.bin")
          .to(at::kDouble);
  ASSERT_GT(sweep.size(0), 100);
  const at::Tensor velodyne = sweep.narrow(1, 0, 3);
  const at::Tensor range = velodyne.norm(2, {1});
  const at::Tensor elevation = at::asin(velodyne.select(1, 2) / range) * (180.0 / M_PI);
  const at::Tensor ring = (elevation + 15.0) / (30.0 / 7.0);  // beam b at -15° + b·30/7°
  EXPECT_LT((ring - ring.round()).abs().max().item<double>(), 1e-3);
  const at::Tensor azimuth = at::atan2(velodyne.select(1, 1), velodyne.select(1, 0)) * (180 / M_PI);
  EXPECT_LT((azimuth / 2.0 - (azimuth / 2.0).round()).abs().max().item<double>(), 1e-3);
  EXPECT_TRUE(at::allclose(sweep.select(1, 3), at::full({sweep.size(0)}, 0.5, at::kDouble)));
  // Camera frame (x right, y down, z forward) from the Velodyne's (x forward, y left, z up).
  const at::Tensor camera_points =
      at::stack({-velodyne.select(1, 1), -velodyne.select(1, 2), velodyne.select(1, 0)}, 1);
  const data::synth::SynthSample scene =
      data::synth::synthesize(options.scene, options.seed, options.camera, options.synth);
  const at::Tensor directions = (camera_points / range.unsqueeze(1)).unsqueeze(1);
  data::synth::RenderOptions ranges;
  ranges.shadows = ranges.ambient_occlusion = false;
  const data::synth::Render cast = data::synth::render_scene(
      scene.scene, directions, at::ones({directions.size(0), 1}, at::kBool), ranges);
  EXPECT_TRUE(cast.mask.all().item<bool>());
  EXPECT_LT(((cast.distance.squeeze(1) - range).abs() / range).max().item<double>(), 1e-5);

  // The reader: the camera as written, the image as rendered, and on each labelled pixel the
  // distance of the nearest sweep point projecting into it.
  const std::unique_ptr<data::Dataset> train =
      data::open_dataset("kitti-raw", {root.string(), false, (root / "train_files.txt").string()});
  ASSERT_EQ(train->size(), 2);
  const data::Sample sample = train->item({0, 0});
  EXPECT_EQ(sample.camera.to_spec(), options.camera.to_spec());
  EXPECT_TRUE(sample.metric);
  EXPECT_TRUE(sample.sparse_labels);
  EXPECT_TRUE(at::allclose(sample.image, scene.sample.image, 0, 0.5 / 255));
  const at::Tensor pixels = options.camera.project(camera_points).pixels;
  std::map<std::pair<int64_t, int64_t>, double> nearest;
  for (int64_t i = 0; i < camera_points.size(0); ++i) {
    if (camera_points[i][2].item<double>() <= 0) continue;
    const double u = pixels[i][0].item<double>(), v = pixels[i][1].item<double>();
    if (!(u >= 0 && v >= 0 && u < 96 && v < 32)) continue;
    const auto key = std::pair{static_cast<int64_t>(v), static_cast<int64_t>(u)};
    const double d = range[i].item<double>();
    if (!nearest.count(key) || d < nearest[key]) nearest[key] = d;
  }
  ASSERT_GT(nearest.size(), 20u);
  EXPECT_EQ(sample.mask.sum().item<int64_t>(), static_cast<int64_t>(nearest.size()));
  for (const auto& [pixel, d] : nearest) {
    EXPECT_TRUE(sample.mask[pixel.first][pixel.second].item<bool>());
    EXPECT_NEAR(sample.distance[pixel.first][pixel.second].item<double>(), d, 1e-4 * d);
  }
  // The summary's density is the reader's, over every frame.
  const std::unique_ptr<data::Dataset> all = data::open_dataset("kitti-raw", {root.string()});
  ASSERT_EQ(all->size(), 3);
  double density = 0;
  for (int64_t i = 0; i < 3; ++i)
    density += all->item({i, 0}).mask.to(at::kDouble).mean().item<double>();
  EXPECT_NEAR(summary.label_density, density / 3, 1e-9);
  EXPECT_GT(summary.label_density, 0.01);
  EXPECT_LT(summary.label_density, 0.15);

  // Bad options, and a root that holds something already: one line, nothing written.
  data::synth::KittiRawDriveOptions fisheye = options;
  fisheye.camera = camera::parse_camera("OPENCV_FISHEYE 96 32 30 30 48 16 0 0 0 0");
  const auto error_of = [](const std::string& out, const data::synth::KittiRawDriveOptions& o) {
    try {
      data::synth::write_kitti_raw_drive(out, o);
    } catch (const std::exception& error) {
      return std::string(error.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error_of((dir / "fisheye").string(), fisheye).find("PINHOLE"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "fisheye"));
  EXPECT_NE(error_of(root.string(), options).find("not an empty folder"), std::string::npos);
  EXPECT_EQ(test::slurp(root / "train_files.txt"), train_drive + " 0 l\n" + train_drive + " 1 l\n");
}

// The command: `omnipoint synth --kitti-raw` writes a root the reader opens; a camera the layout
// cannot hold is one error line and no folder.
TEST(SparseLabels, SynthKittiRawCommandWritesARootOrOneErrorLine) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path dir = test::fresh_process_dir("omnipoint_synth_kitti_raw_cli");
  const std::string common =
      "synth --kitti-raw --scene outdoor --seed 4 --count 2 --held-out 1 --lidar-beams 4 "
      "--lidar-elevation -10 10 --lidar-azimuth-steps 90 --no-shadows --no-ao --threads 1 ";
  const test::CliRun written = test::run_omnipoint(
      common + "--camera \"PINHOLE 48 16 28 28 24 8\" --out " + (dir / "root").string(), dir);
  ASSERT_EQ(written.status, 0) << written.err;
  EXPECT_NE(written.err.find("2 training and 1 held-out frames"), std::string::npos) << written.err;
  EXPECT_EQ(data::open_dataset("kitti-raw", {(dir / "root").string(), false,
                                             (dir / "root" / "test_files.txt").string()})
                ->size(),
            1);
  const test::CliRun bad = test::run_omnipoint(
      common + "--camera \"EQUIRECTANGULAR 48 24\" --out " + (dir / "bad").string(), dir);
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find("PINHOLE"), std::string::npos) << bad.err;
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

// A training config with the drive as a native source: items at the bucket's size (half the
// frames'), flagged sparse, with no sky negatives, and the sparse-depth condition drawn as a
// share of the image's pixels from the labels.
TEST(SparseLabels, NativeKittiRawSourceGivesSparseTrainingItems) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_sparse_source") / "drive";
  data::synth::write_kitti_raw_drive(root.string(), drive_options(3, 0));
  json config = tiny_config(temp_dir("sparse_source"));
  config["data"]["batch_size"] = 3;
  config["data"]["datasets"] = {{{"format", "kitti-raw"},
                                 {"root", root.string()},
                                 {"split", (root / "train_files.txt").string()},
                                 {"options", {{"camera", "image_02"}}},
                                 {"image_size", {48, 16}}}};
  config["conditions"] = {{"probability", 1.0}, {"sparse_ratio", {0.01, 0.01}}};
  const BatchSource source(TrainConfig::from_json(config));
  const TrainingBatch batch = source.batch(0, /*conditions=*/true);
  ASSERT_EQ(batch.image.sizes(), (at::IntArrayRef{3, 3, 16, 48}));
  EXPECT_TRUE(batch.targets.sparse.all().item<bool>());
  EXPECT_FALSE(batch.targets.mask_negative.any().item<bool>());
  EXPECT_TRUE(batch.targets.metric.all().item<bool>());
  for (int64_t k = 0; k < 3; ++k) {
    const at::Tensor mask = batch.targets.mask[k];
    const int64_t labelled = mask.sum().item<int64_t>();
    EXPECT_GT(labelled, 8) << k;
    EXPECT_TRUE((batch.targets.distance[k].masked_select(mask) > 0).all().item<bool>());
    // 1 % of the 768 pixels (not of the labels), at labelled pixels with their distances.
    const at::Tensor condition = batch.condition_sparse_depth[k];
    EXPECT_EQ((condition > 0).sum().item<int64_t>(), 8) << k;
    EXPECT_FALSE(((condition > 0) & ~mask).any().item<bool>());
    EXPECT_TRUE(
        at::equal(at::where(condition > 0, batch.targets.distance[k], condition), condition));
  }
}

// The sparse-label fine-tune (docs/TRAINING.md), small: the tiny network trained from scratch on
// the LiDAR labels of 12 frames scores better on 4 held-out frames than before (the trainer's
// evaluation of data.eval_datasets, before the first step and after the last).
TEST(SparseLabels, FineTuningOnLidarLabelsLowersTheHeldOutError) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_sparse_finetune") / "drive";
  data::synth::write_kitti_raw_drive(root.string(), drive_options(12, 4));
  json config = tiny_config(temp_dir("sparse_finetune"));
  config["data"] = {{"batch_size", 4},
                    {"image_size", {96, 32}},
                    {"num_tokens", {12, 12}},
                    {"datasets",
                     {{{"format", "kitti-raw"},
                       {"root", root.string()},
                       {"split", (root / "train_files.txt").string()}}}},
                    {"eval_datasets",
                     {{{"format", "kitti-raw"},
                       {"root", root.string()},
                       {"split", (root / "test_files.txt").string()}}}}};
  config["stages"] = {{{"stage", 1}, {"steps", 120}, {"lr_backbone", 1e-3}, {"lr_heads", 1e-3}}};
  config["loss"] = {{"weights", {{"gauge", 0.1}}},
                    {"local", {{"levels", {4}}, {"patches_per_item", 8}, {"min_points", 8}}}};
  config["ema"] = {{"decay", 0.9}};
  config["eval_batches"] = 4;
  const TrainConfig train_config = TrainConfig::from_json(config);
  Trainer trainer(train_config, tiny_model(train_config));
  const std::map<std::string, double> before = trainer.evaluate();
  while (!trainer.done()) trainer.train_step();
  const std::map<std::string, double> after = trainer.evaluate();
  for (const char* key : {"points_rel", "metric_rel", "points_delta1", "metric_delta1"}) {
    ASSERT_TRUE(before.count(key) && after.count(key)) << key;
    std::cout << key << ": " << before.at(key) << " -> " << after.at(key) << "\n";
  }
  // The scale-invariant points (the shape of the scene): from scratch, 120 steps teach it. The
  // metric scale head moves about lr per step, too little in 120 steps to learn the scenes'
  // scale from its random start (the bundled model's fine-tune in docs/TRAINING.md does).
  EXPECT_LT(after.at("points_rel"), 0.8 * before.at("points_rel"));
  EXPECT_GT(after.at("points_delta1"), before.at("points_delta1") + 0.1);
}

}  // namespace
}  // namespace omnipoint::train
