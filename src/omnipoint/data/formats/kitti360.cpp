// "kitti360": KITTI-360's fisheye (image_02, image_03) and rectified perspective (image_00,
// image_01) cameras with labels from the Velodyne sweeps or from pre-made distance PNGs (DAC's
// proj_depth layout). Layout (KITTI-360 documentation; DAC's kitti360Scripts fork):
//   ROOT/calibration/image_02.yaml, image_03.yaml   MEI fisheyes (kitti_text.h)
//   ROOT/calibration/perspective.txt                P_rect_0X, R_rect_0X, S_rect_0X
//   ROOT/calibration/calib_cam_to_pose.txt          camera -> GPS/IMU pose frame, per camera
//   ROOT/calibration/calib_cam_to_velo.txt          unrectified image_00 -> Velodyne
//   ROOT/data_2d_raw/SEQ/image_0X/data_rgb/NNNNNNNNNN.png    fisheye frames
//   ROOT/data_2d_raw/SEQ/image_0X/data_rect/NNNNNNNNNN.png   perspective frames
//   ROOT/data_3d_raw/SEQ/velodyne_points/data/NNNNNNNNNN.bin float32 x, y, z, reflectance
// Conventions and their sources:
//   - the calibration chain as the devkit composes it (loadCalibration.py; DAC's
//     kitti360PrepareDepth.py): camera k -> camera 0 is inv(cam_to_pose[00]) · cam_to_pose[k],
//     camera 0 -> Velodyne is calib_cam_to_velo, and a Velodyne point reaches camera k as the
//     inverse of their product; the perspective cameras then rotate by R_rect_0X. The camera
//     axes are ours (x right, y down, z forward, metres);
//   - (u0, v0) of both calibrations in the integer-centre convention: cx = u0 + 0.5 in ours
//     ("principal_point": "corner" is DAC's reading, cx = u0);
//   - the fisheye projection ignores p1, p2 as the devkit's cam2image does ("tangential":
//     "true" applies them, as DAC's ray grid does);
//   - labels ("gt_rule", lidar_labels.h): "nearest" (default) or DAC's published rule. The
//     sweeps are not corrected for the car's motion during a sweep (the devkit's "curl", which
//     DAC's ground truth applies): labels of moving-car sweeps may lie off by that motion;
//   - a list's DEPTH PNG: uint16 / 256 metres (DAC's kitti360PrepareDepth.py), 0 = no label;
//     the fisheye PNGs hold the distance ‖X‖ (the devkit's fisheye depth), a perspective
//     camera's the planar depth z (the devkit's perspective depth), turned into distance here;
//   - "border_mask": an .npy bool (H, W), true = the ego car's border (DAC's
//     mask_{left,right}_fisheye.npy); labels there are dropped.
#include <ATen/ATen.h>

#include <algorithm>
#include <filesystem>
#include <map>
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
#include "omnipoint/io/npy.h"
#include "omnipoint/io/point_cloud.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;

bool is_fisheye(const std::string& camera) {
  return camera == "image_02" || camera == "image_03";
}

// The image folder of a camera's frames: data_rgb (fisheye) or data_rect (perspective).
const char* frame_folder(const std::string& camera) {
  return is_fisheye(camera) ? "data_rgb" : "data_rect";
}

struct Kitti360Options {
  PrincipalPoint reading = PrincipalPoint::kIntegerCentre;
  LidarRule rule = LidarRule::kNearest;
  bool tangential = false;
  std::string border_mask;  // "" none
};

// A frame: its image and, from a list, its depth PNG ("" = from the sweep).
struct Frame {
  std::string image, depth;
};

// The camera of `camera_name` and its transform from the Velodyne frame.
struct CalibratedCamera {
  camera::Camera camera;
  at::Tensor camera_from_velo;
};

CalibratedCamera calibrated_camera(const fs::path& root, const std::string& camera_name,
                                   const Kitti360Options& options) {
  const fs::path calibration = root / "calibration";
  const auto text = [&](const std::string& file) {
    return io::read_file((calibration / file).string());
  };
  const std::string pose_file = (calibration / "calib_cam_to_pose.txt").string();
  const auto to_pose = parse_kitti360_cam_to_pose(text("calib_cam_to_pose.txt"), pose_file);
  if (!to_pose.count(camera_name)) throw std::runtime_error(pose_file + ": no key " + camera_name);
  const at::Tensor velo_from_cam0 = parse_kitti360_cam_to_velo(
      text("calib_cam_to_velo.txt"), (calibration / "calib_cam_to_velo.txt").string());
  const at::Tensor cam0_from_camera =
      at::matmul(at::inverse(to_pose.at("image_00")), to_pose.at(camera_name));
  at::Tensor camera_from_velo = at::inverse(at::matmul(velo_from_cam0, cam0_from_camera));
  if (is_fisheye(camera_name)) {
    const std::string yaml = camera_name + ".yaml";
    return {parse_kitti360_fisheye(text(yaml), (calibration / yaml).string(), options.reading,
                                   options.tangential),
            camera_from_velo};
  }
  const Kitti360Perspective perspective = parse_kitti360_perspective(
      text("perspective.txt"), (calibration / "perspective.txt").string(), camera_name,
      options.reading);
  return {perspective.camera, at::matmul(perspective.rect_from_camera, camera_from_velo)};
}

// The camera (image_0X) and the sequence (the folder above it) of a frame image
// .../SEQ/image_0X/data_rgb/NNNNNNNNNN.png.
std::string camera_of(const fs::path& image) {
  return image.parent_path().parent_path().filename().string();
}
fs::path sweep_of(const fs::path& root, const fs::path& image) {
  const std::string sequence = image.parent_path().parent_path().parent_path().filename().string();
  return root / "data_3d_raw" / sequence / "velodyne_points" / "data" /
         (image.stem().string() + ".bin");
}

// The files a frame is read from: its image, its depth PNG or else its sweep, the calibration
// files of its camera (calibrated_camera) and the border mask.
std::vector<std::string> frame_sources(const fs::path& root, const Frame& frame,
                                       const Kitti360Options& options) {
  const fs::path calibration = root / "calibration";
  const std::string camera_name = camera_of(frame.image);
  std::vector<std::string> sources = {
      frame.image, frame.depth.empty() ? sweep_of(root, frame.image).string() : frame.depth,
      (calibration / "calib_cam_to_pose.txt").string(),
      (calibration / "calib_cam_to_velo.txt").string(),
      (calibration / (is_fisheye(camera_name) ? camera_name + ".yaml" : "perspective.txt"))
          .string()};
  if (!options.border_mask.empty()) sources.push_back(options.border_mask);
  return sources;
}

Sample read_kitti360_frame(const fs::path& root, const Frame& frame,
                           const Kitti360Options& options) {
  const std::string camera_name = camera_of(frame.image);
  check_kitti_camera_name(camera_name, frame.image);
  const CalibratedCamera calibrated = calibrated_camera(root, camera_name, options);
  const camera::Camera& camera = calibrated.camera;
  const int64_t width = camera.width(), height = camera.height();
  Sample sample{camera, io::read_image(frame.image), {}, {}, true};
  if (sample.image.size(0) != height || sample.image.size(1) != width)
    throw std::runtime_error(
        frame.image + ": the image is " + std::to_string(sample.image.size(1)) + "x" +
        std::to_string(sample.image.size(0)) + " but the calibration's " + camera_name + " is " +
        std::to_string(width) + "x" + std::to_string(height));
  if (!frame.depth.empty()) {
    at::Tensor distance =
        formats::read_depth_png(frame.depth, 16, 1, width, height).to(at::kFloat) / 256;
    if (!is_fisheye(camera_name)) {  // planar depth z -> distance along the unit ray
      const at::Tensor ray_z = camera.ray_map(at::kFloat).rays.select(-1, 2);
      distance =
          at::where(ray_z > 1e-3, distance / ray_z.clamp_min(1e-3), at::zeros_like(distance));
    }
    sample.distance = distance.contiguous();
  } else {
    const at::Tensor velo =
        io::read_kitti_bin(sweep_of(root, frame.image).string()).to(at::kDouble);
    const at::Tensor& transform = calibrated.camera_from_velo;
    const at::Tensor points = at::matmul(velo, transform.narrow(0, 0, 3).narrow(1, 0, 3).t()) +
                              transform.narrow(0, 0, 3).select(1, 3);
    LidarProjection projection;
    projection.rule = options.rule;
    projection.devkit_shift = principal_point_shift(options.reading);
    projection.round = !is_fisheye(camera_name);  // the devkit's perspective cam2image rounds
    sample.distance = lidar_labels(points, camera, projection).distance;
  }
  if (!options.border_mask.empty()) {
    const at::Tensor border = io::read_npy(options.border_mask);
    if (border.scalar_type() != at::kBool || border.dim() != 2 || border.size(0) != height ||
        border.size(1) != width)
      throw std::runtime_error(options.border_mask + ": expected a bool (" +
                               std::to_string(height) + ", " + std::to_string(width) +
                               ") border mask (true = the ego car)");
    sample.distance = at::where(border, at::zeros_like(sample.distance), sample.distance);
  }
  sample.mask = sample.distance > 0;
  sample.sparse_labels = true;
  return sample;
}

std::vector<Frame> all_frames(const fs::path& root, const std::string& camera) {
  std::vector<Frame> frames;
  for (const fs::path& sequence : formats::sorted_entries(root / "data_2d_raw"))
    for (const fs::path& image : formats::sorted_entries(sequence / camera / frame_folder(camera)))
      if (image.extension() == ".png" && fs::is_regular_file(sweep_of(root, image)))
        frames.push_back({image.string(), ""});
  return frames;
}

// A DAC list (kitti_text.h): every image, and its depth PNG or else its sweep, must exist.
std::vector<Frame> listed_frames(const fs::path& root, const std::string& list) {
  std::vector<Frame> frames;
  for (const Kitti360ListEntry& entry : parse_kitti360_list(io::read_file(list), list)) {
    const std::string where = list + " line " + std::to_string(entry.line) + ": ";
    for (const std::string& path : {entry.image, entry.depth})
      if (path.find("..") != std::string::npos || fs::path(path).is_absolute())
        throw std::runtime_error(where + "\"" + path + "\" is not a path under the root");
    const fs::path image = root / entry.image;
    if (!fs::is_regular_file(image)) throw std::runtime_error(where + "no image " + image.string());
    check_kitti_camera_name(camera_of(image), where + image.string());
    Frame frame{image.string(), entry.depth.empty() ? "" : (root / entry.depth).string()};
    if (!frame.depth.empty() && !fs::is_regular_file(frame.depth))
      throw std::runtime_error(where + "no depth PNG " + frame.depth);
    if (frame.depth.empty() && !fs::is_regular_file(sweep_of(root, image)))
      throw std::runtime_error(where + "no Velodyne sweep " + sweep_of(root, image).string());
    frames.push_back(frame);
  }
  return frames;
}

std::unique_ptr<Dataset> open_kitti360(const DatasetLocation& location) {
  const std::string what = "dataset \"" + location.path + "\"";
  const std::string camera = option_or(location, "camera", "image_02");
  check_kitti_camera_name(camera, what);
  Kitti360Options options;
  options.reading =
      parse_principal_point(option_or(location, "principal_point", "integer-centre"), what);
  options.rule = parse_lidar_rule(option_or(location, "gt_rule", "nearest"), what);
  const std::string tangential = option_or(location, "tangential", "false");
  if (tangential != "true" && tangential != "false")
    throw std::invalid_argument(what + ": tangential \"" + tangential +
                                "\": expected true or false");
  options.tangential = tangential == "true";
  options.border_mask = option_or(location, "border_mask", "");
  if (!fs::is_directory(location.path))
    throw std::runtime_error(what + ": not a directory (the KITTI-360 root)");
  std::vector<Frame> frames;
  try {
    frames = location.split.empty() ? all_frames(location.path, camera)
                                    : listed_frames(location.path, location.split);
  } catch (const std::exception& error) {
    throw std::runtime_error(what + ": " + error.what());
  }
  if (frames.empty())
    throw std::runtime_error(what + ": holds no KITTI-360 frames (data_2d_raw/SEQ/" + camera + "/" +
                             frame_folder(camera) +
                             "/*.png with data_3d_raw/SEQ/velodyne_points/data/*.bin)");
  auto depths = std::make_shared<std::map<std::string, std::string>>();
  std::vector<std::string> images;
  for (const Frame& frame : frames) {
    images.push_back(frame.image);
    (*depths)[frame.image] = frame.depth;
  }
  const fs::path root = location.path;
  return std::make_unique<ListDataset>(
      std::move(images),
      [root, depths, options](const std::string& image) {
        return read_kitti360_frame(root, {image, depths->at(image)}, options);
      },
      [root, depths, options](const std::string& image) {
        return frame_sources(root, {image, depths->at(image)}, options);
      });
}

}  // namespace

DatasetFormat kitti360_format() {
  return {"kitti360",
          "the KITTI-360 root: calibration/ (image_0X.yaml, perspective.txt, "
          "calib_cam_to_pose.txt, calib_cam_to_velo.txt), data_2d_raw/SEQ/image_0X/"
          "{data_rgb,data_rect}/*.png, data_3d_raw/SEQ/velodyne_points/data/*.bin; or a list of "
          "DAC's form with uint16/256 distance PNGs",
          {{"camera",
            "image_02 (default) or image_03 (fisheyes), image_00 or image_01 "
            "(perspective); a list's image paths name their own"},
           {"principal_point",
            "integer-centre (default, the devkit's: cx = u0 + 0.5) or corner (DAC's: cx = u0)"},
           {"gt_rule",
            "nearest (default: nearest point on the pixel holding it) or dac (DAC's "
            "published labels: truncated coordinates, last point wins)"},
           {"tangential", "false (default: p1, p2 ignored, as the devkit) or true (DAC's rays)"},
           {"border_mask",
            "an .npy bool (H, W) of the ego car's border (DAC's "
            "mask_{left,right}_fisheye.npy); no labels there"}},
          {},
          open_kitti360};
}

}  // namespace omnipoint::data
