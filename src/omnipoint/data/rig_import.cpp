#include "omnipoint/data/rig_import.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
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

// ---- nuScenes (the devkit's schema, docs/schema_nuscenes.md) ----

using json = nlohmann::json;

// A rotation quaternion is accepted when | |q| - 1 | is at most this (the tables print 16
// digits), then normalised, so the rig's rotation is orthonormal to rounding.
constexpr double kQuaternionNormTolerance = 1e-6;

// One table file: a JSON array of objects. Errors name the file, the record (by its token) and
// the key: "v1.0-mini/sensor.json: record 725903f5...: channel: expected a string".
class NuScenesTable {
 public:
  // `keep`, when given, filters the records while parsing (sample_data.json has millions).
  explicit NuScenesTable(const fs::path& path,
                         const std::function<bool(const json&)>& keep = nullptr)
      : path_(path.string()) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw std::runtime_error(path_ + ": cannot read (a nuScenes table)");
    const json::parser_callback_t filter = [&keep](int depth, json::parse_event_t event,
                                                   json& parsed) {
      return !(keep && depth == 1 && event == json::parse_event_t::object_end && !keep(parsed));
    };
    try {
      records_ = json::parse(file, filter);
    } catch (const json::exception& error) {
      throw std::invalid_argument(path_ + ": not valid JSON: " + error.what());
    }
    if (!records_.is_array()) throw std::invalid_argument(path_ + ": expected an array of records");
    for (size_t i = 0; i < records_.size(); ++i)
      if (!records_[i].is_object())
        throw std::invalid_argument(path_ + ": record " + std::to_string(i) + ": not an object");
  }
  const std::string& path() const { return path_; }
  const json& records() const { return records_; }

  [[noreturn]] void fail(const json& record, const std::string& key,
                         const std::string& what) const {
    const auto token = record.find("token");
    const std::string name =
        token != record.end() && token->is_string() ? token->get<std::string>() : "(no token)";
    throw std::invalid_argument(path_ + ": record " + name + ": " + key + ": " + what);
  }
  const json& get(const json& record, const std::string& key) const {
    const auto value = record.find(key);
    if (value == record.end()) fail(record, key, "missing");
    return *value;
  }
  std::string text(const json& record, const std::string& key) const {
    const json& value = get(record, key);
    if (!value.is_string()) fail(record, key, "expected a string");
    return value.get<std::string>();
  }
  std::vector<double> numbers(const json& record, const std::string& key, size_t count,
                              const std::string& meaning) const {
    const json& value = get(record, key);
    const auto bad = [&] { fail(record, key, "expected " + meaning); };
    if (!value.is_array() || value.size() != count) bad();
    std::vector<double> numbers;
    for (const json& number : value) {
      if (!number.is_number() || !std::isfinite(number.get<double>())) bad();
      numbers.push_back(number.get<double>());
    }
    return numbers;
  }
  // The records by token (the tables' primary key).
  std::map<std::string, const json*> by_token() const {
    std::map<std::string, const json*> index;
    for (const json& record : records_) index[text(record, "token")] = &record;
    return index;
  }

 private:
  std::string path_;
  json records_;
};

// sensor -> ego of a calibrated_sensor record: [R(rotation) | translation]. The devkit takes a
// sensor's points into the ego frame by rotating with Quaternion(rotation).rotation_matrix (a
// Hamilton (w, x, y, z) quaternion), then adding translation (nuscenes.py,
// map_pointcloud_to_image).
at::Tensor nuscenes_ego_from_sensor(const NuScenesTable& table, const json& record) {
  const std::vector<double> t = table.numbers(record, "translation", 3, "3 numbers (metres)");
  const std::vector<double> q = table.numbers(record, "rotation", 4, "4 numbers (w, x, y, z)");
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(std::abs(norm - 1) <= kQuaternionNormTolerance)) {
    char text[96];
    std::snprintf(text, sizeof text, "the quaternion (w, x, y, z) is not of unit norm (|q| = %.9g)",
                  norm);
    table.fail(record, "rotation", text);
  }
  const double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
  return at::tensor({1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y), t[0],
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x), t[1],
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y), t[2],  //
                     0.0, 0.0, 0.0, 1.0},
                    at::kDouble)
      .view({4, 4});
}

// The PINHOLE camera of a camera's calibrated_sensor record, camera_intrinsic = [[fx, 0, cx],
// [0, fy, cy], [0, 0, 1]], projecting u = fx x / z + cx (the devkit's view_points). The devkit
// draws those u over matplotlib's imshow, whose pixel i is centred at i: integer centres, so
// ours (pixel i centred at i + 0.5) is cx + 0.5 (`reading` integer-centre; corner: cx).
camera::Camera nuscenes_camera(const NuScenesTable& calibrated, const json& record, int64_t width,
                               int64_t height, PrincipalPoint reading) {
  const json& rows = calibrated.get(record, "camera_intrinsic");
  const auto bad = [&](const std::string& what) {
    calibrated.fail(record, "camera_intrinsic", what);
  };
  if (!rows.is_array() || rows.size() != 3) bad("expected 3 rows of 3 numbers");
  double k[3][3];
  for (size_t r = 0; r < 3; ++r) {
    if (!rows[r].is_array() || rows[r].size() != 3) bad("expected 3 rows of 3 numbers");
    for (size_t c = 0; c < 3; ++c) {
      if (!rows[r][c].is_number() || !std::isfinite(rows[r][c].get<double>()))
        bad("expected 3 rows of 3 finite numbers");
      k[r][c] = rows[r][c].get<double>();
    }
  }
  if (k[0][1] != 0 || k[1][0] != 0 || k[2][0] != 0 || k[2][1] != 0 || k[2][2] != 1)
    bad("expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (a PINHOLE has no skew)");
  if (!(k[0][0] > 0 && k[1][1] > 0)) bad("the focal lengths must be positive");
  const double shift = principal_point_shift(reading);
  return camera::Camera("PINHOLE", width, height,
                        {k[0][0], k[1][1], k[0][2] + shift, k[1][2] + shift});
}

// The folder holding the tables: DIR itself, or the one v1.0-* folder of a dataroot.
fs::path nuscenes_table_folder(const fs::path& dir) {
  if (!fs::is_directory(dir))
    throw std::runtime_error(dir.string() + ": not a folder (a nuScenes v1.0-* metadata folder)");
  if (fs::exists(dir / "calibrated_sensor.json")) return dir;
  std::vector<fs::path> versions;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir))
    if (entry.is_directory() && entry.path().filename().string().rfind("v1.0-", 0) == 0 &&
        fs::exists(entry.path() / "calibrated_sensor.json"))
      versions.push_back(entry.path());
  if (versions.size() == 1) return versions.front();
  throw std::runtime_error(
      dir.string() + (versions.empty() ? ": no calibrated_sensor.json (give the v1.0-* metadata "
                                         "folder)"
                                       : ": several v1.0-* metadata folders; give one"));
}

// One channel of the scene's first sample: its key-frame sample_data and calibrated_sensor.
struct NuScenesChannel {
  const json* data = nullptr;
  const json* calibration = nullptr;
  std::string modality;
};

io::Rig import_nuscenes(const fs::path& dir, const std::string& scene_name,
                        const std::vector<std::string>& cameras, PrincipalPoint reading,
                        std::vector<std::string>* notes) {
  const fs::path folder = nuscenes_table_folder(dir);
  const NuScenesTable scenes(folder / "scene.json");
  if (scenes.records().empty()) throw std::invalid_argument(scenes.path() + ": no scenes");
  const json* scene = &scenes.records().front();
  if (scene_name.empty()) {
    if (notes)
      notes->push_back("nuScenes scene " + scenes.text(*scene, "name") +
                       " (the first in scene.json; --scene picks another)");
  } else {
    scene = nullptr;
    for (const json& record : scenes.records())
      if (scenes.text(record, "name") == scene_name) scene = &record;
    if (!scene) throw std::invalid_argument(scenes.path() + ": no scene named " + scene_name);
  }
  const std::string name = scenes.text(*scene, "name");
  const std::string first_sample = scenes.text(*scene, "first_sample_token");

  // Records of other samples are dropped while parsing; one without a sample_token is kept so
  // that it is reported.
  const NuScenesTable data(folder / "sample_data.json", [&first_sample](const json& record) {
    const auto sample = record.find("sample_token");
    return sample == record.end() || !sample->is_string() || *sample == first_sample;
  });
  const NuScenesTable calibrated(folder / "calibrated_sensor.json");
  const NuScenesTable sensors(folder / "sensor.json");
  const std::map<std::string, const json*> calibration_of = calibrated.by_token();
  const std::map<std::string, const json*> sensor_of = sensors.by_token();

  std::map<std::string, NuScenesChannel> channels;
  for (const json& record : data.records()) {
    data.text(record, "sample_token");
    const json& key_frame = data.get(record, "is_key_frame");
    if (!key_frame.is_boolean()) data.fail(record, "is_key_frame", "expected true or false");
    if (!key_frame.get<bool>()) continue;
    const std::string calibration_token = data.text(record, "calibrated_sensor_token");
    if (!calibration_of.count(calibration_token))
      data.fail(record, "calibrated_sensor_token", "no such record in " + calibrated.path());
    const json& calibration = *calibration_of.at(calibration_token);
    const std::string sensor_token = calibrated.text(calibration, "sensor_token");
    if (!sensor_of.count(sensor_token))
      calibrated.fail(calibration, "sensor_token", "no such record in " + sensors.path());
    const json& sensor = *sensor_of.at(sensor_token);
    const std::string channel = sensors.text(sensor, "channel");
    if (channels.count(channel))
      data.fail(record, "calibrated_sensor_token",
                "a second key frame of channel " + channel + " in sample " + first_sample);
    channels[channel] = {&record, &calibration, sensors.text(sensor, "modality")};
  }
  if (channels.empty())
    throw std::invalid_argument(data.path() + ": no key-frame records of sample " + first_sample +
                                " (the first of scene " + name + ")");

  std::vector<std::string> chosen = cameras;
  if (chosen.empty())
    for (const json& sensor : sensors.records()) {
      const auto channel = channels.find(sensors.text(sensor, "channel"));
      if (channel != channels.end() && channel->second.modality == "camera")
        chosen.push_back(channel->first);
    }
  io::Rig rig;
  rig.frame = "ego";
  for (const std::string& camera : chosen) {
    const auto channel = channels.find(camera);
    if (channel == channels.end() || channel->second.modality != "camera")
      throw std::invalid_argument("rig import: scene " + name + " has no camera channel " + camera);
    const json& record = *channel->second.data;
    int64_t size[2] = {0, 0};
    for (int i = 0; i < 2; ++i) {
      const char* key = i == 0 ? "width" : "height";
      const json& value = data.get(record, key);
      if (!value.is_number_integer() || value.get<int64_t>() <= 0)
        data.fail(record, key, "expected a positive whole number of pixels");
      size[i] = value.get<int64_t>();
    }
    const json& calibration = *channel->second.calibration;
    rig.cameras.push_back({camera,
                           nuscenes_camera(calibrated, calibration, size[0], size[1], reading),
                           nuscenes_ego_from_sensor(calibrated, calibration)});
  }
  const auto lidar = channels.find("LIDAR_TOP");
  if (lidar != channels.end())
    rig.lidar = io::RigLidar{"nuscenes", io::lidar_floats_per_point("nuscenes"),
                             nuscenes_ego_from_sensor(calibrated, *lidar->second.calibration)};
  else if (notes)
    notes->push_back("scene " + name + " has no LIDAR_TOP key frame: the rig has no LiDAR");
  return rig;
}
}  // namespace

void RigImportOptions::Check() const {
  const auto fail = [](const std::string& why) {
    throw std::invalid_argument("rig import: " + why);
  };
  if (!kitti360_root.empty() + !kitti_raw_date.empty() + !nuscenes_json.empty() != 1)
    fail("give one calibration: a KITTI-360 root, a KITTI raw date folder or a nuScenes folder");
  if (!nuscenes_scene.empty() && nuscenes_json.empty())
    fail("a scene is chosen only in a nuScenes folder");
  if (nuscenes_json.empty())
    for (const std::string& camera : cameras) check_kitti_camera_name(camera, "rig import");
  parse_principal_point(principal_point, "rig import");
}

io::Rig import_rig(const RigImportOptions& options, std::vector<std::string>* notes) {
  options.Check();
  const PrincipalPoint reading = parse_principal_point(options.principal_point, "rig import");
  if (!options.nuscenes_json.empty())
    return import_nuscenes(options.nuscenes_json, options.nuscenes_scene, options.cameras, reading,
                           notes);
  const std::vector<std::string>& cameras =
      options.cameras.empty() ? kKittiCameras : options.cameras;
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
