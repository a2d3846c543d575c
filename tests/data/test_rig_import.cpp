// `rig import` (data/rig_import.h, io::write_rig): KITTI-360, KITTI raw and nuScenes
// calibrations written from known rigs, imported, written and read back with io::read_rig: every camera's intrinsics
// and body-from-camera pose equal the truth (a transposed or inverted transform would not);
// bad calibrations give one error line and leave no rig file.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "driving_files.h"
#include "kitti_calibration_files.h"
#include "nuscenes_files.h"
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

// The quaternions print 16 digits: the poses agree with the truth to rounding.
constexpr double kNuScenesPoseTolerance = 1e-6;

void expect_nuscenes_sensor(const at::Tensor& read, const test::NuScenesSensor& truth) {
  ASSERT_EQ(read.sizes(), (at::IntArrayRef{4, 4})) << truth.channel;
  const at::Tensor pose = truth.pose();
  EXPECT_LT((read - pose).abs().max().item<double>(), kNuScenesPoseTolerance)
      << truth.channel << "\nread\n"
      << read << "\ntruth\n"
      << pose;
  // A conjugated quaternion (the transposed rotation) would be far from it.
  at::Tensor conjugated = pose.clone();
  conjugated.narrow(0, 0, 3).narrow(1, 0, 3).copy_(pose.narrow(0, 0, 3).narrow(1, 0, 3).t());
  EXPECT_GT((read - conjugated).abs().max().item<double>(), 0.1) << truth.channel;
}

TEST(RigImport, NuScenesCamerasAndLidarInTheEgoFrame) {
  const fs::path root = test::fresh_process_dir("omnipoint_rig_import_nuscenes");
  const test::NuScenesMetadata truth;
  truth.write(root / "v1.0-mini");
  RigImportOptions options;
  options.nuscenes_json = (root / "v1.0-mini").string();
  std::vector<std::string> notes;
  io::write_rig((root / "rig.json").string(), import_rig(options, &notes));
  const io::Rig rig = io::read_rig((root / "rig.json").string());
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0], "nuScenes scene scene-0001 (the first in scene.json; --scene picks another)");
  EXPECT_EQ(rig.frame, "ego");
  // The cameras in sensor.json's order; the radar is no camera.
  ASSERT_EQ(rig.cameras.size(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    const test::NuScenesSensor& sensor = truth.sensors[i];
    const io::RigCamera& read = rig.cameras[i];
    EXPECT_EQ(read.name, sensor.channel);
    // The devkit's integer pixel centres: cx = cx_K + 0.5 in ours.
    const camera::Camera camera("PINHOLE", sensor.size[0], sensor.size[1],
                                {sensor.intrinsic[0], sensor.intrinsic[1],
                                 sensor.intrinsic[2] + 0.5, sensor.intrinsic[3] + 0.5});
    expect_camera(read.camera, camera, sensor.channel);
    expect_nuscenes_sensor(read.body_from_camera, sensor);
  }
  // CAM_FRONT looks forward (ego x) with its x axis to the right (ego -y), as nuScenes' does.
  const at::Tensor front = rig.cameras[0].body_from_camera;
  EXPECT_NEAR(front[0][2].item<double>(), 1.0, 1e-9);
  EXPECT_NEAR(front[1][0].item<double>(), -1.0, 1e-9);
  EXPECT_NEAR(front[2][1].item<double>(), -1.0, 1e-9);
  ASSERT_TRUE(rig.lidar.has_value());
  EXPECT_EQ(rig.lidar->format, "nuscenes");
  EXPECT_EQ(rig.lidar->floats_per_point, 5);
  expect_nuscenes_sensor(rig.lidar->body_from_lidar, truth.sensors[6]);

  // The dataroot holding the one v1.0-* folder; the second scene's calibration; some cameras in
  // the order given; the corner reading of the principal point.
  options.nuscenes_json = root.string();
  options.nuscenes_scene = "scene-0002";
  options.cameras = {"CAM_BACK_LEFT", "CAM_FRONT"};
  options.principal_point = "corner";
  notes.clear();
  const io::Rig second = import_rig(options, &notes);
  EXPECT_TRUE(notes.empty());
  ASSERT_EQ(second.cameras.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const test::NuScenesSensor sensor = truth.sensor(options.cameras[i], 1);
    EXPECT_EQ(second.cameras[i].name, sensor.channel);
    const camera::Camera camera(
        "PINHOLE", sensor.size[0], sensor.size[1],
        {sensor.intrinsic[0], sensor.intrinsic[1], sensor.intrinsic[2], sensor.intrinsic[3]});
    expect_camera(second.cameras[i].camera, camera, sensor.channel);
    expect_nuscenes_sensor(second.cameras[i].body_from_camera, sensor);
  }
  expect_nuscenes_sensor(second.lidar->body_from_lidar, truth.sensor("LIDAR_TOP", 1));
}

TEST(RigImport, BadNuScenesTablesGiveOneLineAndNoRigFile) {
  const fs::path root = test::fresh_process_dir("omnipoint_rig_import_nuscenes_bad");
  const fs::path folder = root / "v1.0-mini";
  const test::NuScenesMetadata truth;
  const fs::path rig = root / "rig.json";
  RigImportOptions options;
  options.nuscenes_json = folder.string();
  const auto import_to_rig = [&](const RigImportOptions& given) {
    return [&rig, given] { io::write_rig(rig.string(), import_rig(given)); };
  };
  // Each case edits one table of a fresh copy of the tables.
  using json = nlohmann::json;
  const auto write_with = [&](const std::string& name, const std::function<void(json&)>& edit) {
    truth.write(folder);
    for (auto [file, table] : truth.tables())
      if (file == name) {
        edit(table);
        write_text(folder / file, table.dump());
      }
  };
  const auto record_of = [](json& table, const std::string& token) -> json& {
    for (json& record : table)
      if (record["token"] == token) return record;
    throw std::logic_error("no record " + token);
  };
  const std::string front = "calibration_1_CAM_FRONT";
  const std::string table = (folder / "calibrated_sensor.json").string();

  // Wrong quaternions: not of unit norm; missing; three numbers.
  write_with("calibrated_sensor.json", [&](json& t) {
    for (json& q : record_of(t, front)["rotation"]) q = q.get<double>() * 1.01;
  });
  expect_error(import_to_rig(options), {table, front, "rotation", "not of unit norm", "1.01"});
  write_with("calibrated_sensor.json", [&](json& t) { record_of(t, front).erase("rotation"); });
  expect_error(import_to_rig(options), {table, front, "rotation: missing"});
  write_with("calibrated_sensor.json", [&](json& t) {
    record_of(t, front)["rotation"] = {1.0, 0.0, 0.0};
  });
  expect_error(import_to_rig(options), {table, "rotation", "4 numbers (w, x, y, z)"});
  // A camera without intrinsics, one with skew, a translation of strings.
  write_with("calibrated_sensor.json",
             [&](json& t) { record_of(t, front)["camera_intrinsic"] = json::array(); });
  expect_error(import_to_rig(options), {table, front, "camera_intrinsic"});
  write_with("calibrated_sensor.json",
             [&](json& t) { record_of(t, front)["camera_intrinsic"][0][1] = 0.5; });
  expect_error(import_to_rig(options), {table, "camera_intrinsic", "skew"});
  write_with("calibrated_sensor.json", [&](json& t) {
    record_of(t, front)["translation"] = {"1", "2", "3"};
  });
  expect_error(import_to_rig(options), {table, front, "translation"});
  // Malformed JSON, a missing table.
  truth.write(folder);
  write_text(folder / "calibrated_sensor.json", "[{\"token\": \"a\",");
  expect_error(import_to_rig(options), {table, "not valid JSON"});
  truth.write(folder);
  fs::remove(folder / "sensor.json");
  expect_error(import_to_rig(options), {(folder / "sensor.json").string(), "cannot read"});
  // sample_data: no image size; a calibration token of no record; no sample_token.
  const std::string data = (folder / "sample_data.json").string();
  write_with("sample_data.json", [&](json& t) { record_of(t, "data_1a_CAM_BACK").erase("width"); });
  expect_error(import_to_rig(options), {data, "data_1a_CAM_BACK", "width: missing"});
  write_with("sample_data.json", [&](json& t) {
    record_of(t, "data_1a_CAM_BACK")["calibrated_sensor_token"] = "nowhere";
  });
  expect_error(import_to_rig(options), {data, "calibrated_sensor_token", "no such record"});
  write_with("sample_data.json",
             [&](json& t) { record_of(t, "data_2a_CAM_BACK").erase("sample_token"); });
  expect_error(import_to_rig(options), {data, "data_2a_CAM_BACK", "sample_token: missing"});
  // scene.json: not an array; an unknown scene; an unknown camera channel; a radar as a camera.
  write_with("scene.json", [&](json& t) { t = json::object(); });
  expect_error(import_to_rig(options), {(folder / "scene.json").string(), "array"});
  truth.write(folder);
  RigImportOptions scene = options;
  scene.nuscenes_scene = "scene-0099";
  expect_error(import_to_rig(scene), {"scene.json", "no scene named scene-0099"});
  RigImportOptions camera = options;
  camera.cameras = {"CAM_SIDE"};
  expect_error(import_to_rig(camera), {"scene-0001", "no camera channel CAM_SIDE"});
  camera.cameras = {"RADAR_FRONT"};
  expect_error(import_to_rig(camera), {"no camera channel RADAR_FRONT"});
  // Not a folder; a folder without tables; a scene without a nuScenes folder.
  RigImportOptions missing = options;
  missing.nuscenes_json = (root / "nothing").string();
  expect_error(import_to_rig(missing), {"nothing", "not a folder"});
  missing.nuscenes_json = (root / "empty").string();
  fs::create_directories(root / "empty");
  expect_error(import_to_rig(missing), {"empty", "no calibrated_sensor.json"});
  RigImportOptions kitti;
  kitti.kitti_raw_date = root.string();
  kitti.nuscenes_scene = "scene-0001";
  expect_error(import_to_rig(kitti), {"scene", "nuScenes"});
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

TEST(RigImportCommand, NuScenesNamesTheSceneItChose) {
  const fs::path folder = test::fresh_process_dir("omnipoint_rig_import_nuscenes_cli");
  const test::NuScenesMetadata truth;
  truth.write(folder / "v1.0-mini");
  const fs::path rig = folder / "rig.json";
  test::CliRun run = test::run_omnipoint(
      "rig import --nuscenes-json " + folder.string() + " --out " + rig.string(), folder / "run");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out,
            "nuScenes scene scene-0001 (the first in scene.json; --scene picks another)\n" +
                rig.string() +
                ": 6 cameras (CAM_FRONT PINHOLE, CAM_FRONT_RIGHT PINHOLE, CAM_BACK_RIGHT "
                "PINHOLE, CAM_BACK PINHOLE, CAM_BACK_LEFT PINHOLE, CAM_FRONT_LEFT PINHOLE) and a "
                "nuscenes LiDAR in the body frame ego\n");
  expect_nuscenes_sensor(io::read_rig(rig.string()).cameras[3].body_from_camera, truth.sensors[3]);

  write_text(folder / "v1.0-mini" / "sensor.json", "[{\"token\": 1}]");
  const fs::path bad = folder / "bad.json";
  run = test::run_omnipoint(
      "rig import --nuscenes-json " + folder.string() + " --scene scene-0002 --out " + bad.string(),
      folder / "run");
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(run.err, "omnipoint: error: " + (folder / "v1.0-mini" / "sensor.json").string() +
                         ": record (no token): token: expected a string\n");
  EXPECT_FALSE(fs::exists(bad));
  run = test::run_omnipoint("rig import --kitti360 " + folder.string() + " --nuscenes-json " +
                                folder.string() + " --out " + bad.string(),
                            folder / "run");
  EXPECT_NE(run.status, 0);
  EXPECT_FALSE(fs::exists(bad));
}

}  // namespace
}  // namespace omnipoint::data
