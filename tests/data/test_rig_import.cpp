// `rig import` (data/rig_import.h, io::write_rig): KITTI-360 and KITTI raw calibrations written
// from known rigs, imported, written and read back with io::read_rig: every camera's intrinsics
// and body-from-camera pose equal the truth (a transposed or inverted transform would not);
// bad calibrations give one error line and leave no rig file.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "driving_files.h"
#include "kitti_calibration_files.h"
#include "omnipoint/data/rig_import.h"
#include "omnipoint/io/rig.h"
#include "support/cli_run.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::expect_error;
using test::write_text;

// Calibrations print 7 significant digits (%e): poses composed from them agree to ~1e-6.
constexpr double kPoseTolerance = 1e-5;

void expect_pose(const at::Tensor& read, const at::Tensor& truth, const std::string& what) {
  ASSERT_EQ(read.sizes(), (at::IntArrayRef{4, 4})) << what;
  const double off = (read - truth).abs().max().item<double>();
  EXPECT_LT(off, kPoseTolerance) << what << "\nread\n" << read << "\ntruth\n" << truth;
}

void expect_camera(const camera::Camera& read, const camera::Camera& truth,
                   const std::string& what) {
  EXPECT_EQ(read.model_name(), truth.model_name()) << what;
  EXPECT_EQ(read.width(), truth.width()) << what;
  EXPECT_EQ(read.height(), truth.height()) << what;
  ASSERT_EQ(read.params().size(), truth.params().size()) << what;
  for (size_t i = 0; i < read.params().size(); ++i)
    EXPECT_NEAR(read.params()[i], truth.params()[i], 1e-9) << what << " parameter " << i;
}

// The rig as written and read back by the rig file reader.
io::Rig imported(const RigImportOptions& options, const fs::path& path) {
  io::write_rig(path.string(), import_rig(options));
  return io::read_rig(path.string());
}

TEST(RigImport, Kitti360CamerasAndVelodyneInThePoseFrame) {
  const fs::path root = test::fresh_process_dir("omnipoint_rig_import_kitti360");
  const test::Kitti360Calibration truth;
  truth.write(root);
  RigImportOptions options;
  options.kitti360_root = root.string();
  const io::Rig rig = imported(options, root / "rig.json");
  EXPECT_EQ(rig.frame, "kitti360_pose");
  ASSERT_EQ(rig.cameras.size(), 4u);
  for (int camera = 0; camera < 4; ++camera) {
    const io::RigCamera& read = rig.cameras[static_cast<size_t>(camera)];
    const std::string name = "image_0" + std::to_string(camera);
    EXPECT_EQ(read.name, name);
    expect_camera(read.camera, truth.camera(camera), name);
    expect_pose(read.body_from_camera, truth.body_from_camera[static_cast<size_t>(camera)], name);
    // What a transposed rotation or an inverted transform would give is far from it.
    const at::Tensor inverted = at::inverse(truth.body_from_camera[static_cast<size_t>(camera)]);
    EXPECT_GT((read.body_from_camera - inverted).abs().max().item<double>(), 0.1) << name;
  }
  ASSERT_TRUE(rig.lidar.has_value());
  EXPECT_EQ(rig.lidar->format, "kitti");
  expect_pose(rig.lidar->body_from_lidar, truth.body_from_velo, "velodyne");

  // A choice of cameras, in the order given; DAC's principal point reading.
  options.cameras = {"image_03", "image_00"};
  options.principal_point = "corner";
  const io::Rig two = imported(options, root / "two.json");
  ASSERT_EQ(two.cameras.size(), 2u);
  EXPECT_EQ(two.cameras[0].name, "image_03");
  EXPECT_NEAR(two.cameras[0].camera.params()[2], truth.mei[1][2], 1e-9);  // cx = u0
  expect_pose(two.cameras[1].body_from_camera, truth.body_from_camera[0], "image_00");
}

TEST(RigImport, KittiRawCamerasInTheVelodyneFrame) {
  const fs::path date = test::fresh_process_dir("omnipoint_rig_import_kitti_raw") / "2011_09_26";
  const test::KittiRawCalibration truth;
  truth.write(date);
  RigImportOptions options;
  options.kitti_raw_date = date.string();
  const io::Rig rig = imported(options, date / "rig.json");
  EXPECT_EQ(rig.frame, "velodyne");
  ASSERT_EQ(rig.cameras.size(), 4u);
  for (int camera = 0; camera < 4; ++camera) {
    const io::RigCamera& read = rig.cameras[static_cast<size_t>(camera)];
    const std::string name = "image_0" + std::to_string(camera);
    EXPECT_EQ(read.name, name);
    expect_camera(read.camera, truth.intrinsics[static_cast<size_t>(camera)].camera(), name);
    expect_pose(read.body_from_camera, truth.velo_from_camera(camera), name);
    EXPECT_GT((read.body_from_camera - truth.camera_from_velo(camera)).abs().max().item<double>(),
              0.1)
        << name;
  }
  ASSERT_TRUE(rig.lidar.has_value());
  expect_pose(rig.lidar->body_from_lidar, at::eye(4, at::kDouble), "velodyne");
}

TEST(RigImport, WrittenRigReadsBackExactly) {
  const fs::path folder = test::fresh_process_dir("omnipoint_rig_write");
  const test::Kitti360Calibration truth;
  truth.write(folder);
  RigImportOptions options;
  options.kitti360_root = folder.string();
  const io::Rig rig = import_rig(options);
  io::write_rig((folder / "rig.json").string(), rig);
  const io::Rig read = io::read_rig((folder / "rig.json").string());
  ASSERT_EQ(read.cameras.size(), rig.cameras.size());
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    EXPECT_EQ(read.cameras[i].camera, rig.cameras[i].camera) << i;
    EXPECT_TRUE(at::equal(read.cameras[i].body_from_camera, rig.cameras[i].body_from_camera)) << i;
  }
  EXPECT_TRUE(at::equal(read.lidar->body_from_lidar, rig.lidar->body_from_lidar));
  EXPECT_EQ(io::format_rig(read), io::format_rig(rig));
}

TEST(RigImport, BadCalibrationsGiveOneLineAndNoRigFile) {
  const fs::path folder = test::fresh_process_dir("omnipoint_rig_import_bad");
  const fs::path date = folder / "2011_09_26";
  const test::KittiRawCalibration raw;
  raw.write(date);
  const fs::path rig = folder / "rig.json";
  const auto import_to_rig = [&](const RigImportOptions& options) {
    return [&rig, options] { io::write_rig(rig.string(), import_rig(options)); };
  };
  RigImportOptions options;
  options.kitti_raw_date = date.string();

  write_text(date / "calib_cam_to_cam.txt", raw.cam_to_cam_text("P_rect_02"));
  expect_error(import_to_rig(options), {"calib_cam_to_cam.txt", "P_rect_02"});
  raw.write(date);
  fs::remove(date / "calib_velo_to_cam.txt");
  expect_error(import_to_rig(options), {"calib_velo_to_cam.txt"});
  raw.write(date);
  // A Velodyne rotation scaled by 1.01 is no rotation: the rig reader's check refuses it.
  test::KittiRawCalibration scaled = raw;
  scaled.cam0_from_velo = raw.cam0_from_velo.clone();
  scaled.cam0_from_velo.narrow(0, 0, 3).narrow(1, 0, 3).mul_(1.01);
  scaled.write(date);
  expect_error(import_to_rig(options), {"body_from_camera", "orthonormal"});
  options.cameras = {"image_07"};
  expect_error(import_to_rig(options), {"image_07"});

  RigImportOptions kitti360;
  kitti360.kitti360_root = (folder / "nothing").string();
  expect_error(import_to_rig(kitti360), {"nothing", "not a folder"});
  const test::Kitti360Calibration calibration;
  calibration.write(folder / "k360");
  kitti360.kitti360_root = (folder / "k360").string();
  fs::remove(folder / "k360" / "calibration" / "image_03.yaml");
  expect_error(import_to_rig(kitti360), {"image_03.yaml"});
  write_text(folder / "k360" / "calibration" / "calib_cam_to_pose.txt",
             "image_00: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  kitti360.cameras = {"image_02"};
  expect_error(import_to_rig(kitti360), {"calib_cam_to_pose.txt", "image_02"});
  RigImportOptions both = kitti360;
  both.kitti_raw_date = date.string();
  expect_error(import_to_rig(both), {"one calibration"});
  EXPECT_FALSE(fs::exists(rig));
}

TEST(RigImportCommand, WritesTheRigOrOneErrorLine) {
  const fs::path folder = test::fresh_process_dir("omnipoint_rig_import_cli");
  const test::Kitti360Calibration truth;
  truth.write(folder);
  const fs::path rig = folder / "rig.json";
  test::CliRun run = test::run_omnipoint(
      "rig import --kitti360 " + folder.string() + " --out " + rig.string(), folder / "run");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.out.find("4 cameras (image_00 PINHOLE, image_01 PINHOLE, image_02 MEI, "
                         "image_03 MEI) and a kitti LiDAR in the body frame kitti360_pose"),
            std::string::npos)
      << run.out;
  expect_pose(io::read_rig(rig.string()).cameras[2].body_from_camera, truth.body_from_camera[2],
              "image_02");

  const fs::path missing = folder / "missing.json";
  run = test::run_omnipoint(
      "rig import --kitti-raw " + (folder / "none").string() + " --out " + missing.string(),
      folder / "run");
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(run.err, "omnipoint: error: " + (folder / "none").string() +
                         ": not a folder (a KITTI raw date folder)\n");
  EXPECT_FALSE(fs::exists(missing));
}

}  // namespace
}  // namespace omnipoint::data
