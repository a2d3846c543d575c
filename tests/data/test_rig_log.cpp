// The "rig-log" reader (data/formats/rig_log.cpp): a manifest of frames with cameras given
// inline or as files, clouds in .bin layouts and transforms inline or as KITTI calibration
// files, written from known points (rig_log_files.h) and read back onto the right pixels, with
// their sources; and its bad inputs.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "driving_files.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/io/image.h"
#include "rig_log_files.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::expect_error;
using test::write_text;

using Truth = test::RigLogTruth;
using test::kRigLogFisheyeTruth;
using test::kRigLogPinholeTruth;

void expect_labels(const Sample& sample, const std::vector<Truth>& truth, const std::string& what) {
  EXPECT_EQ(sample.mask.sum().item<int64_t>(), static_cast<int64_t>(truth.size())) << what;
  for (const Truth& t : truth) {
    const auto col = static_cast<int64_t>(t.u), row = static_cast<int64_t>(t.v);
    EXPECT_TRUE(sample.mask[row][col].item<bool>()) << what << " " << t.u << "," << t.v;
    EXPECT_NEAR(sample.distance[row][col].item<double>(), t.distance, 1e-4) << what;
  }
}

TEST(RigLog, ManifestFramesBecomeSparseLabels) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_rig_log");
  const std::string matrix = test::write_rig_log(root);

  const std::unique_ptr<Dataset> dataset = open_dataset("rig-log", {root.string()});
  ASSERT_EQ(dataset->size(), 2);
  EXPECT_EQ(dataset->item_name({1, 0}),
            (root / "manifest.jsonl").string() + " line 3: " + (root / "side" / "b.png").string());
  EXPECT_EQ(dataset->item_sources({1, 0}),
            (std::vector<std::string>{(root / "side" / "b.png").string(),
                                      (root / "lidar" / "b.bin").string()}));
  const Sample first = dataset->item({0, 0});
  EXPECT_EQ(first.camera.to_spec(), camera::parse_camera(test::kRigLogPinhole).to_spec());
  EXPECT_TRUE(first.metric);
  EXPECT_TRUE(first.sparse_labels);
  expect_labels(first, kRigLogPinholeTruth, "pinhole frame");
  const Sample second = dataset->item({1, 0});
  EXPECT_EQ(second.camera.to_spec(), camera::parse_camera(test::kRigLogFisheye).to_spec());
  expect_labels(second, kRigLogFisheyeTruth, "fisheye frame");

  // A line without a camera takes the option's; a split names another manifest.
  write_text(root / "val.jsonl",
             "{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\", "
             "\"lidar_to_camera\": [" +
                 matrix + "]}\n");
  const Sample optioned =
      open_dataset(
          "rig-log",
          {root.string(), false, (root / "val.jsonl").string(), {{"camera", test::kRigLogPinhole}}})
          ->item({0, 0});
  expect_labels(optioned, kRigLogPinholeTruth, "camera from the option");

  // Bad lines: one error naming the manifest's line and the problem.
  const auto open_with = [&](const std::string& line) {
    write_text(root / "bad.jsonl", "\n" + line + "\n");
    return open_dataset("rig-log", {root.string(), false, (root / "bad.jsonl").string()});
  };
  const std::string bad = (root / "bad.jsonl").string() + " line 2: ";
  expect_error([&] { open_with("{\"image\": \"front/a.png\""); }, {bad, "not a JSON object"});
  expect_error([&] { open_with("{\"lidar\": \"lidar/a.bin\"}"); }, {bad, "\"image\""});
  expect_error([&] { open_with("{\"image\": \"front/x.png\", \"lidar\": \"lidar/a.bin\"}"); },
               {bad, "no file", "x.png"});
  expect_error([&] { open_with("{\"image\": \"../a.png\", \"lidar\": \"lidar/a.bin\"}"); },
               {bad, "not a path under the root"});
  expect_error([&] { open_with("{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\"}"); },
               {bad, "no \"camera\""});
  expect_error(
      [&] {
        open_with(
            "{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\", \"camera\": "
            "\"PINHOLE 32 24 30\", \"lidar_to_camera\": [1, 0, 0, 0, 1, 0, 0, 0, 1]}");
      },
      {bad, "PINHOLE"});
  expect_error(
      [&] {
        open_with(std::string("{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\", "
                              "\"camera\": \"") +
                  test::kRigLogPinhole + "\", \"lidar_to_camera\": [1, 0, 0, 0, 1, 0, 0, 0, 1]}");
      },
      {bad, "got 9"});
  expect_error([&] { open_with("   "); }, {"names no frame"});
  // A cloud that is no whole number of records: the frame's error names the file.
  write_text(root / "lidar" / "a.bin", std::string(18, '\0'));
  expect_error([&] { dataset->item({0, 0}); }, {"a.bin"});
}

}  // namespace
}  // namespace omnipoint::data
