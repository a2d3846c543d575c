// "kitti-raw": the KITTI raw recordings (synced + rectified), a car's own logs with sparse LiDAR
// labels. Layout (KITTI raw devkit, readme.txt):
//   ROOT/DATE/calib_cam_to_cam.txt       S_rect_0X, R_rect_00, P_rect_0X (and the unrectified
//                                        K/D/R/T, unused: the images are rectified)
//   ROOT/DATE/calib_velo_to_cam.txt      R, T: Velodyne -> unrectified camera 0
//   ROOT/DATE/DRIVE/image_0X/data/NNNNNNNNNN.png     the camera's frames
//   ROOT/DATE/DRIVE/velodyne_points/data/NNNNNNNNNN.bin  float32 x, y, z, reflectance
// Conventions, each from the devkit's readme:
//   - a Velodyne point X reaches camera X's image as P_rect_0X · R_rect_00 · (R|T) · X, so in
//     camera X's rectified frame (x right, y down, z forward, metres: ours) it is
//     [I | t_X] · R_rect_00 · (R|T) · X with K t_X = P_rect_0X's fourth column;
//   - (u0, v0) of P_rect follow the integer-centre pixel convention (the devkit rounds a
//     projection to its pixel index), so cx = u0 + 0.5 in ours ("principal_point": "corner"
//     reads cx = u0);
//   - labels: each point's distance ‖X‖ on the pixel whose footprint holds its projection, the
//     nearest point winning a pixel (lidar_labels.h); frames without a sweep are left out.
#include <ATen/ATen.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/kitti_text.h"
#include "omnipoint/data/formats/lidar_labels.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/point_cloud.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;

const char* const kCamToCam = "calib_cam_to_cam.txt";
const char* const kVeloToCam = "calib_velo_to_cam.txt";

// The sweep of a frame image DRIVE/image_0X/data/STEM.png: DRIVE/velodyne_points/data/STEM.bin.
fs::path sweep_of(const fs::path& image) {
  return image.parent_path().parent_path().parent_path() / "velodyne_points" / "data" /
         (image.stem().string() + ".bin");
}

// The date folder of a frame image DATE/DRIVE/image_0X/data/STEM.png, holding the calibration.
fs::path date_of(const fs::path& image) {
  return image.parent_path().parent_path().parent_path().parent_path();
}

// The files a frame is read from: its image, its sweep and the date's two calibrations.
std::vector<std::string> frame_sources(const std::string& image_name) {
  const fs::path image(image_name);
  return {image_name, sweep_of(image).string(), (date_of(image) / kCamToCam).string(),
          (date_of(image) / kVeloToCam).string()};
}

bool is_frame_image(const fs::path& path) {
  const std::string ext = path.extension().string();
  return ext == ".png" || ext == ".jpg";  // .jpg: monodepth2's re-encoded copies
}

// One frame, named by its image path (ROOT/DATE/DRIVE/image_0X/data/STEM.png).
Sample read_kitti_raw_frame(const std::string& image_name, PrincipalPoint reading) {
  const fs::path image(image_name);
  const std::string camera_name = image.parent_path().parent_path().filename().string();
  const fs::path date = date_of(image);
  const std::string cam_calib = (date / kCamToCam).string();
  const std::string velo_calib = (date / kVeloToCam).string();
  const KittiRawCamera camera =
      parse_kitti_raw_camera(io::read_file(cam_calib), cam_calib, camera_name, reading);
  const at::Tensor camera_from_velo = at::matmul(
      camera.camera_from_cam0, io::parse_rigid_transform(io::read_file(velo_calib), velo_calib));

  Sample sample{camera.camera, io::read_image(image_name), {}, {}, true};
  const int64_t width = camera.camera.width(), height = camera.camera.height();
  if (sample.image.size(0) != height || sample.image.size(1) != width)
    throw std::runtime_error(image_name + ": the image is " + std::to_string(sample.image.size(1)) +
                             "x" + std::to_string(sample.image.size(0)) + " but " + cam_calib +
                             " says S_rect " + std::to_string(width) + "x" +
                             std::to_string(height));
  const at::Tensor velo = io::read_kitti_bin(sweep_of(image).string()).to(at::kDouble);
  const at::Tensor points = at::matmul(velo, camera_from_velo.narrow(0, 0, 3).narrow(1, 0, 3).t()) +
                            camera_from_velo.narrow(0, 0, 3).select(1, 3);
  const LidarLabels labels = lidar_labels(points, camera.camera);
  sample.distance = labels.distance;
  sample.mask = labels.mask;
  sample.sparse_labels = true;
  return sample;
}

// Every frame of `camera` with its sweep: dates (folders with calib_cam_to_cam.txt), their
// drives, the drives' frames, in name order.
std::vector<std::string> all_frames(const fs::path& root, const std::string& camera) {
  std::vector<std::string> frames;
  for (const fs::path& date : formats::sorted_entries(root)) {
    if (!fs::is_regular_file(date / kCamToCam)) continue;
    for (const fs::path& drive : formats::sorted_entries(date))
      for (const fs::path& image : formats::sorted_entries(drive / camera / "data"))
        if (is_frame_image(image) && fs::is_regular_file(sweep_of(image)))
          frames.push_back(image.string());
  }
  return frames;
}

// The frames of a split list (kitti_text.h's parse_kitti_raw_list); a frame whose image or
// sweep is missing is an error naming the list's line.
std::vector<std::string> listed_frames(const fs::path& root, const std::string& list,
                                       const std::string& camera) {
  std::vector<std::string> frames;
  for (const KittiRawListEntry& entry : parse_kitti_raw_list(io::read_file(list), list)) {
    char stem[32];
    std::snprintf(stem, sizeof stem, "%010lld", static_cast<long long>(entry.frame));
    const fs::path data =
        root / entry.drive / (entry.camera.empty() ? camera : entry.camera) / "data";
    fs::path image = data / (std::string(stem) + ".png");
    if (!fs::is_regular_file(image) && fs::is_regular_file(data / (std::string(stem) + ".jpg")))
      image = data / (std::string(stem) + ".jpg");
    const std::string where = list + " line " + std::to_string(entry.line) + ": ";
    if (!fs::is_regular_file(image)) throw std::runtime_error(where + "no image " + image.string());
    if (!fs::is_regular_file(sweep_of(image)))
      throw std::runtime_error(where + "no Velodyne sweep " + sweep_of(image).string());
    frames.push_back(image.string());
  }
  return frames;
}

std::unique_ptr<Dataset> open_kitti_raw(const DatasetLocation& location) {
  const std::string what = "dataset \"" + location.path + "\"";
  const std::string camera = option_or(location, "camera", "image_02");
  check_kitti_camera_name(camera, what);
  const PrincipalPoint reading =
      parse_principal_point(option_or(location, "principal_point", "integer-centre"), what);
  if (!fs::is_directory(location.path))
    throw std::runtime_error(what + ": not a directory (the KITTI raw root, holding DATE folders)");
  std::vector<std::string> frames;
  try {
    frames = location.split.empty() ? all_frames(location.path, camera)
                                    : listed_frames(location.path, location.split, camera);
  } catch (const std::exception& error) {
    throw std::runtime_error(what + ": " + error.what());
  }
  if (frames.empty())
    throw std::runtime_error(what + ": holds no KITTI raw frames (DATE/" + kCamToCam +
                             ", DATE/DRIVE/" + camera +
                             "/data/*.png with velodyne_points/data/*.bin)");
  return std::make_unique<ListDataset>(
      std::move(frames),
      [reading](const std::string& image) { return read_kitti_raw_frame(image, reading); },
      frame_sources);
}

}  // namespace

DatasetFormat kitti_raw_format() {
  return {"kitti-raw",
          "the KITTI raw root: DATE/calib_cam_to_cam.txt, DATE/calib_velo_to_cam.txt, "
          "DATE/DRIVE/image_0X/data/*.png and velodyne_points/data/*.bin (sparse LiDAR labels)",
          {{"camera", "image_00 .. image_03 (default image_02); a split list's l/r overrides it"},
           {"principal_point",
            "integer-centre (default, the devkit's: cx = u0 + 0.5) or corner (cx = u0)"}},
          {},
          open_kitti_raw};
}

}  // namespace omnipoint::data
