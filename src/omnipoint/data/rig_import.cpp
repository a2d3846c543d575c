#include "omnipoint/data/rig_import.h"

#include <ATen/ATen.h>

#include <filesystem>
#include <map>
#include <stdexcept>

#include "omnipoint/data/formats/kitti_text.h"
#include "omnipoint/data/formats/lidar_labels.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/point_cloud.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kKittiCameras = {"image_00", "image_01", "image_02", "image_03"};

bool is_fisheye(const std::string& camera) {
  return camera == "image_02" || camera == "image_03";
}

// The inverse of a rigid (4, 4) with its last row exactly [0, 0, 0, 1] (a general inverse leaves
// rounding noise there, which a rig file does not hold).
at::Tensor rigid_inverse(const at::Tensor& matrix) {
  at::Tensor inverse = at::inverse(matrix);
  inverse.select(0, 3).copy_(at::tensor({0.0, 0.0, 0.0, 1.0}, at::kDouble));
  return inverse;
}

io::RigLidar kitti_lidar(const at::Tensor& body_from_lidar) {
  return {"kitti", io::lidar_floats_per_point("kitti"), body_from_lidar};
}

io::Rig import_kitti360(const fs::path& root, const std::vector<std::string>& cameras,
                        PrincipalPoint reading) {
  const fs::path calibration = root / "calibration";
  const auto path = [&](const std::string& file) { return (calibration / file).string(); };
  const std::string pose_file = path("calib_cam_to_pose.txt");
  const auto pose_from = parse_kitti360_cam_to_pose(io::read_file(pose_file), pose_file);
  const std::string velo_file = path("calib_cam_to_velo.txt");
  const at::Tensor velo_from_cam0 = parse_kitti360_cam_to_velo(io::read_file(velo_file), velo_file);
  io::Rig rig;
  rig.frame = "kitti360_pose";
  for (const std::string& name : cameras) {
    if (!pose_from.count(name)) throw std::invalid_argument(pose_file + ": no key " + name);
    if (is_fisheye(name)) {
      const std::string yaml = path(name + ".yaml");
      rig.cameras.push_back({name,
                             parse_kitti360_fisheye(io::read_file(yaml), yaml, reading, false),
                             pose_from.at(name)});
      continue;
    }
    const std::string perspective_file = path("perspective.txt");
    const Kitti360Perspective perspective = parse_kitti360_perspective(
        io::read_file(perspective_file), perspective_file, name, reading);
    // The images are rectified: pose <- unrectified camera <- rectified camera (R_rect⁻¹).
    rig.cameras.push_back(
        {name, perspective.camera,
         at::matmul(pose_from.at(name), rigid_inverse(perspective.rect_from_camera))});
  }
  rig.lidar = kitti_lidar(at::matmul(pose_from.at("image_00"), rigid_inverse(velo_from_cam0)));
  return rig;
}

io::Rig import_kitti_raw(const fs::path& date, const std::vector<std::string>& cameras,
                         PrincipalPoint reading) {
  const std::string cam_file = (date / "calib_cam_to_cam.txt").string();
  const std::string velo_file = (date / "calib_velo_to_cam.txt").string();
  const std::string cam_text = io::read_file(cam_file);
  const at::Tensor cam0_from_velo = io::parse_rigid_transform(io::read_file(velo_file), velo_file);
  io::Rig rig;
  rig.frame = "velodyne";
  for (const std::string& name : cameras) {
    const KittiRawCamera camera = parse_kitti_raw_camera(cam_text, cam_file, name, reading);
    rig.cameras.push_back(
        {name, camera.camera, rigid_inverse(at::matmul(camera.camera_from_cam0, cam0_from_velo))});
  }
  rig.lidar = kitti_lidar(at::eye(4, at::kDouble));
  return rig;
}

}  // namespace

void RigImportOptions::Check() const {
  const auto fail = [](const std::string& why) {
    throw std::invalid_argument("rig import: " + why);
  };
  if (kitti360_root.empty() == kitti_raw_date.empty())
    fail("give one calibration: a KITTI-360 root or a KITTI raw date folder");
  for (const std::string& camera : cameras) check_kitti_camera_name(camera, "rig import");
  parse_principal_point(principal_point, "rig import");
}

io::Rig import_rig(const RigImportOptions& options) {
  options.Check();
  const std::vector<std::string>& cameras =
      options.cameras.empty() ? kKittiCameras : options.cameras;
  const PrincipalPoint reading = parse_principal_point(options.principal_point, "rig import");
  if (!options.kitti360_root.empty()) {
    if (!fs::is_directory(options.kitti360_root))
      throw std::runtime_error(options.kitti360_root + ": not a folder (the KITTI-360 root)");
    return import_kitti360(options.kitti360_root, cameras, reading);
  }
  if (!fs::is_directory(options.kitti_raw_date))
    throw std::runtime_error(options.kitti_raw_date + ": not a folder (a KITTI raw date folder)");
  return import_kitti_raw(options.kitti_raw_date, cameras, reading);
}

}  // namespace omnipoint::data
