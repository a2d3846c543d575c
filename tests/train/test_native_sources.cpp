// A training config, as a user writes it, naming two native sources with sparse LiDAR labels: a
// `kitti-raw` drive (the synthetic engine's, data/synth/kitti_raw_drive.h) and a `rig-log` of a
// rig's own frames (tests/data/rig_log_files.h). A few steps of the tiny network run on it with
// finite losses, and both sources' items are drawn: each source trains at its own image size,
// so a step's size (its aspect bucket) says which source its items came from.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <set>
#include <string>
#include <utility>

#include "data/rig_log_files.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/kitti_raw_drive.h"
#include "omnipoint/io/image.h"
#include "omnipoint/train/trainer.h"
#include "support/scratch_dir.h"
#include "tiny_training.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;

TEST(NativeSources, KittiRawAndRigLogSourcesTrainTogether) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path dir = test::fresh_process_dir("omnipoint_native_sources");
  data::synth::KittiRawDriveOptions drive;
  drive.camera = camera::parse_camera("PINHOLE 96 32 56 56 48 16");
  drive.frames = 2;
  drive.held_out = 0;
  drive.lidar.beams = 8;
  drive.lidar.min_elevation_deg = -15;
  drive.lidar.max_elevation_deg = 15;
  drive.lidar.azimuth_steps = 180;
  drive.synth.render.shadows = false;
  drive.synth.render.ambient_occlusion = false;
  data::synth::write_kitti_raw_drive((dir / "drive").string(), drive);
  test::write_rig_log(dir / "rig");

  // The config file: the kitti-raw drive at 3:1, the rig's frames at 4:3.
  const std::string text = R"({
  "output_dir": ")" + (dir / "run").string() +
                           R"(",
  "seed": 5,
  "threads": 1,
  "model": )" + tiny_model_json().dump() +
                           R"(,
  "data": {
    "batch_size": 2,
    "num_tokens": [4, 4],
    "datasets": [
      {"format": "kitti-raw", "root": ")" +
                           (dir / "drive").string() + R"(",
       "image_size": [48, 16]},
      {"format": "rig-log", "root": ")" +
                           (dir / "rig").string() + R"(",
       "image_size": [32, 24]}
    ]
  },
  "conditions": {"probability": 0.5, "sparse_ratio": [0.01, 0.02]},
  "loss": {"local": {"levels": [4], "patches_per_item": 4, "min_points": 8}},
  "stages": [
    {"stage": 1, "steps": 4, "lr_backbone": 1e-3, "lr_heads": 1e-3},
    {"stage": 2, "steps": 4, "lr_backbone": 5e-4, "lr_heads": 5e-4}
  ],
  "checkpoint_every": 0,
  "log_every": 1
})";
  test::write_text(dir / "train.json", text);
  const TrainConfig config = TrainConfig::load((dir / "train.json").string());
  ASSERT_EQ(config.datasets.size(), 2u);

  Trainer trainer(config, tiny_model(config));
  std::set<std::pair<int64_t, int64_t>> sizes;
  while (!trainer.done()) {
    const StepRecord record = trainer.train_step();
    EXPECT_FALSE(record.skipped) << "step " << record.step;
    EXPECT_TRUE(std::isfinite(record.loss)) << "step " << record.step;
    sizes.insert({record.width, record.height});
  }
  EXPECT_EQ(trainer.step(), 8);
  // Both sources drawn: the drive's 48x16 steps and the rig's 32x24 ones.
  EXPECT_EQ(sizes, (std::set<std::pair<int64_t, int64_t>>{{48, 16}, {32, 24}}));
  EXPECT_TRUE(trainer.batch_source().skipped_samples().empty());
}

}  // namespace
}  // namespace omnipoint::train
