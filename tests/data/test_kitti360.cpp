// The "kitti360" reader (data/formats/kitti360.cpp): a fisheye and a perspective camera written
// in KITTI-360's layout (calibration files as the devkit's, sweeps in the Velodyne frame through
// the camera -> pose -> camera 0 -> Velodyne chain) from known points, read back onto the
// right pixels with the right distances under both label rules; DAC's depth-PNG lists; bad
// inputs.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "driving_files.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::expect_error;
using test::frame_stem;
using test::kitti_numbers;
using test::rigid;
using test::rotation;
using test::transformed;
using test::write_text;

const char* const kSequence = "2013_05_28_drive_0000_sync";
constexpr int64_t kSize = 64;  // the fisheye's width and height
// The fisheye's MEI calibration: gamma1, gamma2, u0, v0, xi, k1, k2, p1, p2 (p1, p2 large
// enough that applying them would move labels by pixels).
constexpr double kGamma = 30, kU0 = 31.3, kV0 = 32.2, kXi = 1.1, kK1 = 0.02, kK2 = 0.01, kP1 = 0.02,
                 kP2 = -0.015;
constexpr int64_t kRectWidth = 40, kRectHeight = 30;
constexpr double kRectFocal = 35, kRectU0 = 19.2, kRectV0 = 14.6;

// The rig: camera -> pose for image_00 and image_02, image_00 -> Velodyne, R_rect_00.
struct Rig {
  at::Tensor pose_from_cam0 =
      rigid(rotation(0.0, 0.6, 0.8, 1.3), at::tensor({1.57, 0.004, -0.65}, at::kDouble));
  at::Tensor pose_from_cam2 =
      rigid(rotation(0.8, 0.0, 0.6, -1.1), at::tensor({0.73, -0.15, -0.86}, at::kDouble));
  at::Tensor velo_from_cam0 =
      rigid(rotation(0.0, 0.0, 1.0, 0.03), at::tensor({0.81, -0.32, 0.8}, at::kDouble));
  at::Tensor rect_from_cam0 = rigid(rotation(1.0, 0.0, 0.0, 0.01), at::zeros({3}, at::kDouble));
  // Points (N, 3) in a camera's frame -> the Velodyne frame.
  at::Tensor velodyne_from(const std::string& camera, const at::Tensor& points) const {
    const at::Tensor cam0 =
        camera == "image_02"
            ? transformed(at::matmul(at::inverse(pose_from_cam0), pose_from_cam2), points)
            : transformed(at::inverse(rect_from_cam0), points);  // image_00: rectified
    return transformed(velo_from_cam0, cam0);
  }
};

camera::Camera fisheye() {  // ours: (u0, v0) + 0.5, p1 = p2 = 0 (the devkit's projection)
  return camera::Camera("MEI", kSize, kSize,
                        {kGamma, kGamma, kU0 + 0.5, kV0 + 0.5, kXi, kK1, kK2, 0, 0});
}
camera::Camera perspective() {
  return camera::Camera("PINHOLE", kRectWidth, kRectHeight,
                        {kRectFocal, kRectFocal, kRectU0 + 0.5, kRectV0 + 0.5});
}

std::string fisheye_yaml(const std::string& model = "MEI") {
  const auto line = [](const char* key, double value) {
    return std::string("   ") + key + ": " + kitti_numbers(at::tensor({value}, at::kDouble)) + "\n";
  };
  return "%YAML:1.0\nmodel_type: " + model +
         "\ncamera_name: image_02\nimage_width: 64\nimage_height: 64\nmirror_parameters:\n" +
         line("xi", kXi) + "distortion_parameters:\n" + line("k1", kK1) + line("k2", kK2) +
         line("p1", kP1) + line("p2", kP2) + "projection_parameters:\n" + line("gamma1", kGamma) +
         line("gamma2", kGamma) + line("u0", kU0) + line("v0", kV0);
}

void write_calibration(const fs::path& root, const Rig& rig) {
  const fs::path calibration = root / "calibration";
  const auto row_major_3x4 = [](const at::Tensor& m) { return kitti_numbers(m.narrow(0, 0, 3)); };
  write_text(calibration / "image_02.yaml", fisheye_yaml());
  write_text(calibration / "calib_cam_to_pose.txt",
             "image_00: " + row_major_3x4(rig.pose_from_cam0) +
                 "\nimage_01: " + row_major_3x4(rig.pose_from_cam0) +
                 "\nimage_02: " + row_major_3x4(rig.pose_from_cam2) +
                 "\nimage_03: " + row_major_3x4(rig.pose_from_cam2) + "\n");
  write_text(calibration / "calib_cam_to_velo.txt", row_major_3x4(rig.velo_from_cam0) + "\n");
  const at::Tensor p =
      at::tensor({kRectFocal, 0.0, kRectU0, 0.0, 0.0, kRectFocal, kRectV0, 0.0, 0.0, 0.0, 1.0, 0.0},
                 at::kDouble);
  write_text(
      calibration / "perspective.txt",
      "calib_time: 09-Jan-2012 13:57:47\nS_rect_00: " + kitti_numbers(at::tensor({40.0, 30.0})) +
          "\nR_rect_00: " + kitti_numbers(rig.rect_from_cam0.narrow(0, 0, 3).narrow(1, 0, 3)) +
          "\nP_rect_00: " + kitti_numbers(p) + "\n");
}

struct Truth {
  int64_t col, row;
  double du, dv, distance;
};

// The points of `truth` in the camera's frame.
at::Tensor truth_points(const camera::Camera& camera, const std::vector<Truth>& truth) {
  std::vector<double> pixels, distances;
  for (const Truth& t : truth) {
    pixels.insert(pixels.end(), {t.col + t.du, t.row + t.dv});
    distances.push_back(t.distance);
  }
  const auto n = static_cast<int64_t>(truth.size());
  const camera::Rays rays = camera.unproject(at::tensor(pixels, at::kDouble).view({n, 2}));
  EXPECT_TRUE(rays.valid.all().item<bool>());
  return rays.rays * at::tensor(distances, at::kDouble).view({n, 1});
}

fs::path image_path(const fs::path& root, const std::string& camera, int frame) {
  return root / "data_2d_raw" / kSequence / camera /
         (camera == "image_02" ? "data_rgb" : "data_rect") / (frame_stem(frame) + ".png");
}

void write_frame(const fs::path& root, const Rig& rig, const std::string& camera, int frame,
                 const at::Tensor& points, int64_t width, int64_t height) {
  test::write_sweep(
      root / "data_3d_raw" / kSequence / "velodyne_points" / "data" / (frame_stem(frame) + ".bin"),
      rig.velodyne_from(camera, points));
  const fs::path image = image_path(root, camera, frame);
  fs::create_directories(image.parent_path());
  io::write_image_png(image.string(), at::full({height, width, 3}, 40 + frame, at::kByte));
}

// Quarter-pixel offsets both ways (a half-pixel mistake moves some to a neighbour); one far
// off the axis (beyond 90° from it where the MEI lens reaches).
const std::vector<Truth> kFisheyeTruth = {{31, 32, 0.25, 0.75, 5.5},
                                          {10, 20, 0.75, 0.25, 9.0},
                                          {50, 12, 0.25, 0.25, 14.25},
                                          {40, 45, 0.75, 0.75, 3.5},
                                          {61, 33, 0.75, 0.25, 7.75}};
const std::vector<Truth> kPerspectiveTruth = {{5, 6, 0.25, 0.75, 8.0}, {30, 20, 0.75, 0.25, 12.5}};

void expect_labels(const Sample& sample, const std::vector<Truth>& truth, bool dac,
                   const std::string& what) {
  EXPECT_EQ(sample.mask.sum().item<int64_t>(), static_cast<int64_t>(truth.size())) << what;
  for (const Truth& t : truth) {
    // DAC's rule truncates the devkit's coordinates (ours - 0.5): a quarter past the pixel's
    // start is the pixel before.
    const int64_t col = dac && t.du < 0.5 ? t.col - 1 : t.col;
    const int64_t row = dac && t.dv < 0.5 ? t.row - 1 : t.row;
    EXPECT_TRUE(sample.mask[row][col].item<bool>()) << what << " pixel " << col << "," << row;
    EXPECT_NEAR(sample.distance[row][col].item<double>(), t.distance, 1e-4) << what;
  }
}

TEST(Kitti360, FisheyeAndPerspectiveSweepsThroughTheCalibrationChain) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_kitti360");
  const Rig rig;
  write_calibration(root, rig);
  // Fisheye frame 0: the truth, then a point 3x farther on the first truth's ray (written last:
  // DAC's rule keeps it, ours the nearer one).
  const at::Tensor points = truth_points(fisheye(), kFisheyeTruth);
  write_frame(root, rig, "image_02", 0, at::cat({points, points.narrow(0, 0, 1) * 3}), kSize,
              kSize);
  write_frame(root, rig, "image_00", 1, truth_points(perspective(), kPerspectiveTruth), kRectWidth,
              kRectHeight);

  const std::unique_ptr<Dataset> dataset = open_dataset("kitti360", {root.string()});
  ASSERT_EQ(dataset->size(), 1);
  EXPECT_EQ(dataset->item_name({0, 0}), image_path(root, "image_02", 0).string());
  const Sample sample = dataset->item({0, 0});
  EXPECT_EQ(sample.camera.to_spec(), fisheye().to_spec());
  EXPECT_TRUE(sample.metric);
  EXPECT_TRUE(sample.sparse_labels);
  EXPECT_EQ(sample.image.size(0), kSize);
  expect_labels(sample, kFisheyeTruth, false, "fisheye, nearest");
  // The files the frame is read from (data convert's manifest), each present.
  const fs::path calibration = root / "calibration";
  std::vector<std::string> sources = {
      image_path(root, "image_02", 0).string(),
      (root / "data_3d_raw" / kSequence / "velodyne_points" / "data" / "0000000000.bin").string(),
      (calibration / "calib_cam_to_pose.txt").string(),
      (calibration / "calib_cam_to_velo.txt").string(), (calibration / "image_02.yaml").string()};
  EXPECT_EQ(dataset->item_sources({0, 0}), sources);
  for (const std::string& source : sources) EXPECT_TRUE(fs::is_regular_file(source)) << source;

  // DAC's rule: truncated devkit coordinates, the last point on a pixel wins, z > 0 only.
  const Sample dac =
      open_dataset("kitti360", {root.string(), false, "", {{"gt_rule", "dac"}}})->item({0, 0});
  std::vector<Truth> dac_truth;
  for (const Truth& t : kFisheyeTruth)
    if (truth_points(fisheye(), {t})[0][2].item<double>() > 0) dac_truth.push_back(t);
  dac_truth[0].distance *= 3;  // the farther point, written last
  EXPECT_LT(dac_truth.size(), kFisheyeTruth.size()) << "the test needs a point with z < 0";
  expect_labels(dac, dac_truth, true, "fisheye, dac");

  // DAC's rays apply p1, p2 (our camera then has them), and its principal point is cx = u0.
  const Sample tangential =
      open_dataset(
          "kitti360",
          {root.string(), false, "", {{"tangential", "true"}, {"principal_point", "corner"}}})
          ->item({0, 0});
  EXPECT_EQ(tangential.camera.params()[2], kU0);
  EXPECT_EQ(tangential.camera.params()[7], kP1);

  // The perspective camera: rectified by R_rect_00; the devkit rounds, as ours does.
  const std::unique_ptr<Dataset> rect =
      open_dataset("kitti360", {root.string(), false, "", {{"camera", "image_00"}}});
  const Sample rectified = rect->item({0, 0});
  EXPECT_EQ(rect->item_sources({0, 0})[4], (calibration / "perspective.txt").string());
  EXPECT_EQ(rectified.camera.to_spec(), perspective().to_spec());
  expect_labels(rectified, kPerspectiveTruth, false, "perspective");
  expect_labels(
      open_dataset("kitti360",
                   {root.string(), false, "", {{"camera", "image_00"}, {"gt_rule", "dac"}}})
          ->item({0, 0}),
      kPerspectiveTruth, false, "perspective, dac (rounded as the devkit)");

  // The ego car's border mask drops labels under it.
  at::Tensor border = at::zeros({kSize, kSize}, at::kBool);
  border[32][31] = true;
  io::write_npy((root / "mask_left_fisheye.npy").string(), border);
  const Sample masked =
      open_dataset(
          "kitti360",
          {root.string(), false, "", {{"border_mask", (root / "mask_left_fisheye.npy").string()}}})
          ->item({0, 0});
  EXPECT_FALSE(masked.mask[32][31].item<bool>());
  EXPECT_EQ(masked.mask.sum().item<int64_t>(), sample.mask.sum().item<int64_t>() - 1);
  EXPECT_EQ(
      open_dataset(
          "kitti360",
          {root.string(), false, "", {{"border_mask", (root / "mask_left_fisheye.npy").string()}}})
          ->item_sources({0, 0})
          .back(),
      (root / "mask_left_fisheye.npy").string());
}

TEST(Kitti360, DacListsWithDistancePngs) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_kitti360_list");
  const Rig rig;
  write_calibration(root, rig);
  // DAC's layout: data_2d_raw_subset/SEQ/image_02/data_rgb/F.png, proj_depth/SEQ/image_02/F.png
  // (uint16, metres * 256).
  const fs::path image =
      root / "data_2d_raw_subset" / kSequence / "image_02" / "data_rgb" / "0000000010.png";
  fs::create_directories(image.parent_path());
  io::write_image_png(image.string(), at::zeros({kSize, kSize, 3}, at::kByte));
  at::Tensor stored = at::zeros({kSize, kSize}, at::kInt);
  stored[3][7] = 1283;    // 5.01171875 m
  stored[60][2] = 20480;  // 80 m
  const fs::path depth = root / "proj_depth" / kSequence / "image_02" / "0000000010.png";
  fs::create_directories(depth.parent_path());
  io::write_image_png(depth.string(), stored);
  const fs::path list = root / "kitti360_val_fisheye.txt";
  const std::string image_rel = fs::relative(image, root).string();
  const std::string depth_rel = fs::relative(depth, root).string();
  write_text(list, image_rel + " " + depth_rel + " 30.0000\n");
  const Sample sample =
      open_dataset("kitti360", {root.string(), false, list.string()})->item({0, 0});
  EXPECT_EQ(sample.mask.sum().item<int64_t>(), 2);
  EXPECT_EQ(sample.distance[3][7].item<float>(), 1283.0f / 256);
  EXPECT_EQ(sample.distance[60][2].item<float>(), 80.0f);
  // A listed frame is read from its depth PNG, not a sweep.
  EXPECT_EQ(
      open_dataset("kitti360", {root.string(), false, list.string()})->item_sources({0, 0})[1],
      depth.string());

  // An 8-bit depth PNG, one of another size, a list naming a missing file, a bad calibration.
  io::write_image_png(depth.string(), at::zeros({kSize, kSize}, at::kByte));
  expect_error(
      [&] {
        open_dataset("kitti360", {root.string(), false, list.string()})->item({0, 0});
      },
      {depth.string(), "expected a 16-bit grey PNG, got an 8-bit grey one"});
  io::write_image_png(depth.string(), at::zeros({kSize, kSize + 1}, at::kInt));
  expect_error(
      [&] {
        open_dataset("kitti360", {root.string(), false, list.string()})->item({0, 0});
      },
      {depth.string(), "65x64", "64x64"});
  write_text(list, image_rel + " proj_depth/missing.png\n");
  expect_error(
      [&] {
        open_dataset("kitti360", {root.string(), false, list.string()});
      },
      {list.string() + " line 1", "no depth PNG"});
  write_text(list, "../elsewhere.png\n");
  expect_error(
      [&] {
        open_dataset("kitti360", {root.string(), false, list.string()});
      },
      {"line 1", "not a path under the root"});
  write_text(list, image_rel + " " + depth_rel + "\n");
  write_text(root / "calibration" / "image_02.yaml", fisheye_yaml("KANNALA_BRANDT"));
  expect_error(
      [&] {
        open_dataset("kitti360", {root.string(), false, list.string()})->item({0, 0});
      },
      {"image_02.yaml", "KANNALA_BRANDT"});
  expect_error(
      [&] {
        open_dataset("kitti360", {root.string(), false, "", {{"gt_rule", "x"}}});
      },
      {"gt_rule", "\"x\""});
  expect_error([&] { open_dataset("kitti360", {(root / "nothing").string()}); },
               {"not a directory"});
}

}  // namespace
}  // namespace omnipoint::data
