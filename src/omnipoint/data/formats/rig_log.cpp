// "rig-log": a user's own car logs without KITTI's folder names. ROOT/manifest.jsonl (or the
// split: another manifest), one JSON object a line, one frame each, paths relative to ROOT:
//   {"image": "front/000123.jpg",
//    "camera": SPEC | "FILE",             a camera spec (DESIGN.md's forms: a COLMAP line or
//                                          the JSON object), or a camera file (cameras.txt,
//                                          JSON); absent: the "camera" option's
//    "lidar": "lidar/000123.bin",          .bin (float32 records), .pcd or .ply
//    "lidar_to_camera": [16 or 12 numbers] | "FILE",   camera-from-LiDAR, row-major, or a file
//                                          of predict's --lidar-to-camera forms (4x4/3x4 text,
//                                          .npy, KITTI calib_velo_to_cam.txt / calib.txt)
//    "lidar_format": "kitti" | "nuscenes" | N}          floats per .bin record (default kitti)
// Labels: the cloud through lidar_to_camera, projected into the camera, each point's distance
// on the pixel holding it, the nearest winning (lidar_labels.h); the camera's axes are ours
// (x right, y down, z forward, metres) and its pixel centres at i + 0.5 (DESIGN.md).
#include <ATen/ATen.h>

#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/lidar_labels.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/point_cloud.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// One frame, everything but the files' contents resolved at open.
struct RigFrame {
  int64_t line = 0;  // of the manifest
  std::string image, lidar;
  camera::Camera camera;
  at::Tensor camera_from_lidar;
  int64_t floats_per_point = 4;
};

// A path field under the root; missing, not a string, leaving the root or naming no file
// -> an error.
std::string file_field(const json& line, const char* key, const fs::path& root) {
  const auto found = line.find(key);
  if (found == line.end() || !found->is_string())
    throw std::invalid_argument(std::string("\"") + key + "\" must be a path (a string)");
  const std::string path = found->get<std::string>();
  if (path.find("..") != std::string::npos || fs::path(path).is_absolute())
    throw std::invalid_argument(std::string("\"") + key + "\": \"" + path +
                                "\" is not a path under the root");
  const fs::path full = root / path;
  if (!fs::is_regular_file(full)) throw std::invalid_argument("no file " + full.string());
  return full.string();
}

camera::Camera frame_camera(const json& line, const fs::path& root,
                            const std::string& default_camera) {
  const auto found = line.find("camera");
  if (found == line.end()) {
    if (default_camera.empty())
      throw std::invalid_argument("no \"camera\", and no camera option for all frames");
    return camera::parse_camera(default_camera);
  }
  if (found->is_object()) return camera::parse_camera(found->dump());
  if (!found->is_string())
    throw std::invalid_argument("\"camera\" must be a spec or a camera file");
  const std::string spec = found->get<std::string>();
  if (camera::is_camera_line(spec)) return camera::parse_camera(spec);
  const std::string file = file_field(line, "camera", root);
  return camera::parse_camera_file(io::read_file(file), file);
}

at::Tensor frame_transform(const json& line, const fs::path& root) {
  const auto found = line.find("lidar_to_camera");
  if (found == line.end()) throw std::invalid_argument("no \"lidar_to_camera\"");
  if (found->is_string())
    return io::read_rigid_transform(file_field(line, "lidar_to_camera", root));
  if (!found->is_array())
    throw std::invalid_argument("\"lidar_to_camera\" must be 16 or 12 numbers or a file");
  std::ostringstream numbers;
  numbers.precision(17);
  for (const json& value : *found) {
    if (!value.is_number())
      throw std::invalid_argument("\"lidar_to_camera\" holds " + value.dump() + ", not a number");
    numbers << value.get<double>() << ' ';
  }
  return io::parse_rigid_transform(numbers.str(), "\"lidar_to_camera\"");
}

int64_t frame_floats_per_point(const json& line) {
  const auto found = line.find("lidar_format");
  if (found == line.end()) return 4;
  return io::lidar_floats_per_point(found->is_string() ? found->get<std::string>() : found->dump());
}

std::vector<RigFrame> read_manifest(const fs::path& root, const std::string& manifest,
                                    const std::string& default_camera) {
  std::vector<RigFrame> frames;
  std::istringstream lines(io::read_file(manifest));
  int64_t number = 0;
  for (std::string text; std::getline(lines, text);) {
    ++number;
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    try {
      const json line = json::parse(text, nullptr, false);
      if (line.is_discarded() || !line.is_object())
        throw std::invalid_argument("not a JSON object");
      RigFrame frame{number,
                     file_field(line, "image", root),
                     file_field(line, "lidar", root),
                     frame_camera(line, root, default_camera),
                     frame_transform(line, root),
                     frame_floats_per_point(line)};
      frames.push_back(std::move(frame));
    } catch (const std::exception& error) {
      throw std::runtime_error(manifest + " line " + std::to_string(number) + ": " + error.what());
    }
  }
  if (frames.empty()) throw std::runtime_error(manifest + ": the manifest names no frame");
  return frames;
}

Sample read_rig_frame(const RigFrame& frame) {
  Sample sample{frame.camera, io::read_image(frame.image), {}, {}, true};
  if (sample.image.size(0) != frame.camera.height() || sample.image.size(1) != frame.camera.width())
    throw std::runtime_error(
        frame.image + ": the image is " + std::to_string(sample.image.size(1)) + "x" +
        std::to_string(sample.image.size(0)) + " but the camera is " + frame.camera.to_spec());
  const at::Tensor lidar =
      io::read_point_cloud(frame.lidar, frame.floats_per_point, "LiDAR").to(at::kDouble);
  const at::Tensor& transform = frame.camera_from_lidar;
  const at::Tensor points = at::matmul(lidar, transform.narrow(0, 0, 3).narrow(1, 0, 3).t()) +
                            transform.narrow(0, 0, 3).select(1, 3);
  const LidarLabels labels = lidar_labels(points, frame.camera);
  sample.distance = labels.distance;
  sample.mask = labels.mask;
  sample.sparse_labels = true;
  return sample;
}

std::unique_ptr<Dataset> open_rig_log(const DatasetLocation& location) {
  const std::string what = "dataset \"" + location.path + "\"";
  if (!fs::is_directory(location.path))
    throw std::runtime_error(what + ": not a directory (the rig log's root)");
  const std::string manifest = location.split.empty()
                                   ? (fs::path(location.path) / "manifest.jsonl").string()
                                   : location.split;
  std::vector<RigFrame> frames;
  try {
    frames = read_manifest(location.path, manifest, option_or(location, "camera", ""));
  } catch (const std::exception& error) {
    throw std::runtime_error(what + ": " + error.what());
  }
  // Items are named "MANIFEST line N: IMAGE" (an image may be listed twice).
  auto by_name = std::make_shared<std::map<std::string, RigFrame>>();
  std::vector<std::string> names;
  for (RigFrame& frame : frames) {
    names.push_back(manifest + " line " + std::to_string(frame.line) + ": " + frame.image);
    by_name->emplace(names.back(), std::move(frame));
  }
  // An item's sources: its image and cloud (`data check` looks for them, `convert` lists them).
  return std::make_unique<ListDataset>(
      std::move(names),
      [by_name](const std::string& name) { return read_rig_frame(by_name->at(name)); },
      [by_name](const std::string& name) {
        const RigFrame& frame = by_name->at(name);
        return std::vector<std::string>{frame.image, frame.lidar};
      });
}

}  // namespace

DatasetFormat rig_log_format() {
  return {"rig-log",
          "a rig's own logs: ROOT/manifest.jsonl, one frame a line {\"image\", \"camera\", "
          "\"lidar\", \"lidar_to_camera\", \"lidar_format\"} (sparse LiDAR labels)",
          {{"camera", "the camera (a spec) of frames whose line has none"}},
          {},
          open_rig_log};
}

}  // namespace omnipoint::data
