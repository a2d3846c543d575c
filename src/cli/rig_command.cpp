// omnipoint rig import: a rig file (docs/RIG.md) from a dataset's calibration.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "omnipoint/data/rig_import.h"
#include "omnipoint/io/rig.h"

namespace omnipoint::cli {
namespace {

void add_import_command(CLI::App& parent) {
  auto* command = parent.add_subcommand(
      "import",
      "Write a rig file from a KITTI-360, KITTI raw or nuScenes calibration: every camera with "
      "its intrinsics and body-from-camera pose, and the LiDAR (docs/RIG.md)");
  auto options = std::make_shared<data::RigImportOptions>();
  auto out = std::make_shared<std::string>();
  auto* kitti360 = command->add_option("--kitti360", options->kitti360_root,
                                       "A KITTI-360 root (its calibration/ folder)");
  auto* kitti_raw =
      command->add_option("--kitti-raw", options->kitti_raw_date,
                          "A KITTI raw date folder (calib_cam_to_cam.txt, calib_velo_to_cam.txt)");
  auto* nuscenes = command->add_option(
      "--nuscenes-json", options->nuscenes_json,
      "A nuScenes metadata folder (v1.0-mini, ...: scene.json, sample_data.json, "
      "calibrated_sensor.json, sensor.json)");
  auto* scene = command->add_option(
      "--scene", options->nuscenes_scene,
      "The nuScenes scene (scene.json name) whose first sample's calibration is read; default "
      "the first");
  kitti360->excludes(kitti_raw)->excludes(nuscenes);
  kitti_raw->excludes(nuscenes);
  scene->needs(nuscenes);
  command->add_option("--out", *out, "The rig file to write")->required();
  command->add_option("--camera", options->cameras,
                      "A camera to import: image_00 .. image_03, or a nuScenes channel such as "
                      "CAM_FRONT (repeatable; default all)");
  command->add_option("--principal-point", options->principal_point,
                      "integer-centre (default, the devkits': cx = u0 + 0.5) or corner (cx = u0)");
  command->callback([options, out] {
    std::vector<std::string> notes;
    const io::Rig rig = data::import_rig(*options, &notes);
    for (const std::string& note : notes) std::cout << note << "\n";
    io::write_rig(*out, rig);
    std::cout << *out << ": " << rig.cameras.size() << " cameras";
    for (const io::RigCamera& camera : rig.cameras)
      std::cout << (&camera == &rig.cameras.front() ? " (" : ", ") << camera.name << " "
                << camera.camera.model_name();
    std::cout << ")" << (rig.lidar ? " and a " + rig.lidar->format + " LiDAR" : "")
              << " in the body frame " << rig.frame << "\n";
  });
}

}  // namespace

void add_rig_command(CLI::App& app) {
  auto* rig =
      app.add_subcommand("rig", "Rig files: a vehicle's cameras and LiDAR with their poses");
  rig->require_subcommand(1);
  add_import_command(*rig);
}

}  // namespace omnipoint::cli
