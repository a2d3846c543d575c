// The "kitti-raw" reader (data/formats/kitti_raw.cpp): frames written in the KITTI raw layout
// (calibration text as the devkit's, float32 sweeps in the Velodyne frame) from known points,
// read back onto the right pixels with the right distances; and its bad inputs.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "driving_files.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/io/image.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::expect_error;
using test::frame_stem;
using test::kitti_numbers;
using test::rotation;
using test::write_sweep;
using test::write_text;

const char* const kDate = "2011_09_26";
const char* const kDrive = "2011_09_26_drive_0001_sync";
constexpr int64_t kWidth = 48, kHeight = 36;
constexpr double kFocal = 40, kU0 = 23.3, kV0 = 17.1;

// The calibration of the test rig: R_rect_00, per camera the offset t of P_rect = K [I | t],
// and the Velodyne -> camera 0 transform (the KITTI axes swap, a small tilt and an offset).
struct Rig {
  at::Tensor rect = rotation(0.6, 0.8, 0.0, 0.012);
  at::Tensor velo_rotation = at::matmul(
      rotation(0.0, 0.0, 1.0, 0.02),
      at::tensor({0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0}, at::kDouble).view({3, 3}));
  at::Tensor velo_translation = at::tensor({-0.004, -0.076, -0.272}, at::kDouble);
  at::Tensor offset(int camera) const {  // t of P_rect_0X: image_02 left of 00, 03 right
    const double tx = camera == 0 ? 0.0 : camera == 1 ? -0.54 : camera == 2 ? 0.06 : -0.48;
    return at::tensor({tx, 0.002, 0.003}, at::kDouble);
  }
  // Points (N, 3) in camera X's rectified frame -> the Velodyne frame.
  at::Tensor to_velodyne(const at::Tensor& points, int camera) const {
    const at::Tensor cam0 = at::matmul(points - offset(camera), rect);  // R_rect^T (X - t)
    return at::matmul(cam0 - velo_translation, velo_rotation);          // R^T (X0 - T)
  }
};

std::string cam_to_cam_text(const Rig& rig, bool with_p_rect_02 = true) {
  std::string text = "calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\n";
  const at::Tensor k =
      at::tensor({kFocal, 0.0, kU0, 0.0, kFocal, kV0, 0.0, 0.0, 1.0}, at::kDouble).view({3, 3});
  for (int camera = 0; camera < 4; ++camera) {
    const std::string id = "0" + std::to_string(camera);
    const at::Tensor p = at::cat({k, at::matmul(k, rig.offset(camera)).view({3, 1})}, 1);
    text += "S_" + id + ": 1.392000e+03 5.120000e+02\n";  // the unrectified sensor, unused
    text += "K_" + id + ": " + kitti_numbers(k * 1.1) + "\n";
    text += "D_" + id + ": -3.691481e-01 1.968681e-01 1.353473e-03 5.677587e-04 -6.770705e-02\n";
    text += "R_" + id + ": " + kitti_numbers(at::eye(3, at::kDouble)) + "\n";
    text += "T_" + id + ": " + kitti_numbers(rig.offset(camera)) + "\n";
    text +=
        "S_rect_" + id + ": " + kitti_numbers(at::tensor({double(kWidth), double(kHeight)})) + "\n";
    text += "R_rect_" + id + ": " +
            kitti_numbers(camera == 0 ? rig.rect : at::eye(3, at::kDouble)) + "\n";
    if (camera != 2 || with_p_rect_02) text += "P_rect_" + id + ": " + kitti_numbers(p) + "\n";
  }
  return text;
}

std::string velo_to_cam_text(const Rig& rig) {
  return "calib_time: 15-Mar-2012 11:37:16\nR: " + kitti_numbers(rig.velo_rotation) +
         "\nT: " + kitti_numbers(rig.velo_translation) +
         "\ndelta_f: 0.000000e+00 0.000000e+00\ndelta_c: 0.000000e+00 0.000000e+00\n";
}

// A known label: the point at distance `distance` along the ray through (col + du, row + dv).
struct Truth {
  int64_t col, row;
  double du, dv, distance;
};

// The image of a frame: a pattern that tells frames and cameras apart.
at::Tensor frame_image(int frame, int camera) {
  return (at::arange(kHeight * kWidth * 3, at::kLong).view({kHeight, kWidth, 3}) * 7 + frame * 11 +
          camera * 13)
      .remainder(256)
      .to(at::kByte);
}

// Writes frame `frame` of the drive: the images of cameras 2 and 3, and a sweep holding the
// truth's points for camera `camera` (in the file after `extra`, points in its frame too).
void write_frame(const fs::path& root, const Rig& rig, int frame, int camera,
                 const std::vector<Truth>& truth, const at::Tensor& extra = {}) {
  const camera::Camera cam("PINHOLE", kWidth, kHeight, {kFocal, kFocal, kU0 + 0.5, kV0 + 0.5});
  std::vector<double> pixels, distances;
  for (const Truth& t : truth) {
    pixels.insert(pixels.end(), {t.col + t.du, t.row + t.dv});
    distances.push_back(t.distance);
  }
  const int64_t n = static_cast<int64_t>(truth.size());
  const at::Tensor rays = cam.unproject(at::tensor(pixels, at::kDouble).view({n, 2})).rays;
  at::Tensor points = rays * at::tensor(distances, at::kDouble).view({n, 1});
  if (extra.defined()) points = at::cat({points, extra});
  const fs::path drive = root / kDate / kDrive;
  write_sweep(drive / "velodyne_points" / "data" / (frame_stem(frame) + ".bin"),
              rig.to_velodyne(points, camera));
  for (int c : {2, 3}) {
    const fs::path image = drive / ("image_0" + std::to_string(c)) / "data";
    fs::create_directories(image);
    io::write_image_png((image / (frame_stem(frame) + ".png")).string(), frame_image(frame, c));
  }
}

void write_calibration(const fs::path& root, const Rig& rig) {
  write_text(root / kDate / "calib_cam_to_cam.txt", cam_to_cam_text(rig));
  write_text(root / kDate / "calib_velo_to_cam.txt", velo_to_cam_text(rig));
}

// Every truth point labels its pixel with its distance, and nothing else is labelled.
void expect_labels(const Sample& sample, const std::vector<Truth>& truth, const std::string& what) {
  ASSERT_EQ(sample.distance.sizes(), (at::IntArrayRef{kHeight, kWidth})) << what;
  EXPECT_EQ(sample.mask.sum().item<int64_t>(), static_cast<int64_t>(truth.size())) << what;
  const at::Tensor rays = sample.camera.ray_map(at::kDouble).rays;
  for (const Truth& t : truth) {
    EXPECT_TRUE(sample.mask[t.row][t.col].item<bool>())
        << what << " pixel " << t.col << "," << t.row;
    EXPECT_NEAR(sample.distance[t.row][t.col].item<double>(), t.distance, 1e-4) << what;
    // The labelled point (distance · ray at the pixel centre) is the truth's within the
    // pixel's own extent (the truth lies a quarter pixel off the centre in each axis).
    const camera::Camera cam("PINHOLE", kWidth, kHeight, {kFocal, kFocal, kU0 + 0.5, kV0 + 0.5});
    const at::Tensor truth_point =
        cam.unproject(at::tensor({t.col + t.du, t.row + t.dv}, at::kDouble)).rays * t.distance;
    const at::Tensor read_point = rays[t.row][t.col] * sample.distance[t.row][t.col].item<double>();
    EXPECT_LT((truth_point - read_point).norm().item<double>(), t.distance * 0.5 / kFocal) << what;
  }
}

// Points a quarter pixel off their pixel centres, alternately up-left and down-right: reading
// (u0, v0) half a pixel off either way moves some of them onto a neighbouring pixel.
const std::vector<Truth> kTruth2 = {{3, 4, 0.25, 0.75, 4.5},    {20, 10, 0.75, 0.25, 7.25},
                                    {24, 18, 0.25, 0.25, 12.0}, {40, 30, 0.75, 0.75, 3.125},
                                    {0, 0, 0.75, 0.75, 9.5},    {47, 35, 0.25, 0.25, 21.0}};
const std::vector<Truth> kTruth3 = {{10, 5, 0.25, 0.75, 6.0}, {33, 25, 0.75, 0.25, 15.5}};

TEST(KittiRaw, VelodyneSweepsBecomeDistancesOnTheirPixels) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_kitti_raw");
  const Rig rig;
  write_calibration(root, rig);
  // Frame 0 for image_02, with two occluders: a farther point on the pixel of the first truth,
  // written after it (the nearer one labels the pixel), and a point behind the camera whose
  // mirror image would land on pixel (30, 20) (nothing labels it).
  const camera::Camera cam("PINHOLE", kWidth, kHeight, {kFocal, kFocal, kU0 + 0.5, kV0 + 0.5});
  const at::Tensor behind =
      cam.unproject(at::tensor({30.5, 20.5}, at::kDouble)).rays.view({1, 3}) * -5.0;
  const at::Tensor farther =
      cam.unproject(at::tensor({3.5, 4.5}, at::kDouble)).rays.view({1, 3}) * 30.0;
  write_frame(root, rig, 0, 2, kTruth2, at::cat({farther, behind}));
  write_frame(root, rig, 1, 3, kTruth3);

  const std::unique_ptr<Dataset> all =
      open_dataset("kitti-raw", {root.string(), false, "", {{"camera", "image_02"}}});
  ASSERT_EQ(all->size(), 2);
  EXPECT_EQ(all->item_name({0, 0}),
            (root / kDate / kDrive / "image_02" / "data" / "0000000000.png").string());
  const Sample first = all->item({0, 0});
  EXPECT_EQ(first.camera.to_spec(), cam.to_spec());
  EXPECT_TRUE(first.metric);
  EXPECT_TRUE(first.sparse_labels);
  EXPECT_TRUE(at::allclose(first.image, frame_image(0, 2).to(at::kFloat) / 255, 0, 1e-6));
  expect_labels(first, kTruth2, "frame 0 image_02");
  EXPECT_FALSE(first.mask[20][30].item<bool>());
  // The files the frame is read from (data convert's manifest), each present.
  const fs::path date = root / kDate;
  const std::vector<std::string> sources = {
      (date / kDrive / "image_02" / "data" / "0000000000.png").string(),
      (date / kDrive / "velodyne_points" / "data" / "0000000000.bin").string(),
      (date / "calib_cam_to_cam.txt").string(), (date / "calib_velo_to_cam.txt").string()};
  EXPECT_EQ(all->item_sources({0, 0}), sources);
  for (const std::string& source : sources) EXPECT_TRUE(fs::is_regular_file(source)) << source;

  // A split list in monodepth2's form picks frames and cameras (r: image_03).
  const fs::path list = root / "eigen_test.txt";
  write_text(list,
             std::string(kDate) + "/" + kDrive + " 1 r\n\n" + kDate + "/" + kDrive + " 0 l\n");
  const std::unique_ptr<Dataset> split =
      open_dataset("kitti-raw", {root.string(), false, list.string()});
  ASSERT_EQ(split->size(), 2);
  const Sample right = split->item({0, 0});
  EXPECT_NEAR(right.camera.params()[2], kU0 + 0.5, 1e-9);
  EXPECT_TRUE(at::allclose(right.image, frame_image(1, 3).to(at::kFloat) / 255, 0, 1e-6));
  expect_labels(right, kTruth3, "frame 1 image_03");
  expect_labels(split->item({1, 0}), kTruth2, "frame 0 image_02 from the list");

  // DAC's reading of the principal point: cx = u0.
  const std::unique_ptr<Dataset> corner =
      open_dataset("kitti-raw", {root.string(), false, "", {{"principal_point", "corner"}}});
  EXPECT_NEAR(corner->item({0, 0}).camera.params()[2], kU0, 1e-9);
}

TEST(KittiRaw, BadInputsAreOneLineNamingTheFileAndTheProblem) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_kitti_raw_bad");
  const Rig rig;
  const auto open = [&](const std::string& split = "",
                        const std::map<std::string, std::string>& options = {}) {
    return open_dataset("kitti-raw", {root.string(), false, split, options});
  };
  expect_error([&] { open(); }, {"holds no KITTI raw frames"});
  write_calibration(root, rig);
  write_frame(root, rig, 0, 2, kTruth2);
  expect_error([&] { open("", {{"camera", "image_04"}}); }, {"image_04"});
  expect_error([&] { open("", {{"principal_point", "centre"}}); }, {"centre"});
  expect_error([&] { open("", {{"gt_rule", "dac"}}); }, {"gt_rule"});

  // A split list naming a missing frame, and a malformed line.
  const fs::path list = root / "list.txt";
  write_text(list, std::string(kDate) + "/" + kDrive + " 0 l\n" + kDate + "/" + kDrive + " 7\n");
  expect_error([&] { open(list.string()); },
               {list.string() + " line 2", "no image", "0000000007.png"});
  write_text(list, std::string(kDate) + "/" + kDrive + " zero l\n");
  expect_error([&] { open(list.string()); }, {list.string(), "line 1", "zero"});

  // A truncated sweep: a SampleError naming the file.
  const fs::path sweep = root / kDate / kDrive / "velodyne_points" / "data" / "0000000000.bin";
  const std::string bytes = test::slurp(sweep);
  write_text(sweep, bytes.substr(0, bytes.size() - 6));
  expect_error([&] { open()->item({0, 0}); }, {sweep.string()});
  EXPECT_THROW(open()->item({0, 0}), SampleError);
  write_text(sweep, bytes);

  // A calibration missing the camera's projection.
  const fs::path calib = root / kDate / "calib_cam_to_cam.txt";
  write_text(calib, cam_to_cam_text(rig, false));
  expect_error([&] { open()->item({0, 0}); }, {calib.string(), "P_rect_02"});
  write_text(calib, cam_to_cam_text(rig));

  // An image that is not the calibration's size.
  io::write_image_png((root / kDate / kDrive / "image_02" / "data" / "0000000000.png").string(),
                      at::zeros({kHeight, kWidth + 2, 3}, at::kByte));
  expect_error([&] { open()->item({0, 0}); }, {"0000000000.png", "50x36", "48x36"});
}

}  // namespace
}  // namespace omnipoint::data
