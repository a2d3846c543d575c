#pragma once
// A tiny nuScenes metadata folder (the devkit's schema: scene, sample, sample_data,
// calibrated_sensor, sensor tables) written from known calibrations: two scenes, each with its
// own calibration of six cameras, LIDAR_TOP and a radar. The truth is built from axis-angle
// rotations (Rodrigues) and the quaternions from the half-angle formula, independently of the
// importer's quaternion -> matrix conversion.
#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "driving_files.h"

namespace omnipoint::test {

struct NuScenesSensor {
  std::string channel;
  std::string modality;   // camera, lidar, radar
  double axis[3];         // of the sensor -> ego rotation (need not be unit)
  double angle;           // radians
  double translation[3];  // metres
  double intrinsic[4];    // fx, fy, cx, cy (the devkit's camera_intrinsic); cameras only
  int64_t size[2];        // width, height; cameras only

  at::Tensor unit_axis() const {
    const double norm = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    return at::tensor({axis[0] / norm, axis[1] / norm, axis[2] / norm}, at::kDouble);
  }
  // ego_from_sensor (4, 4).
  at::Tensor pose() const {
    const at::Tensor n = unit_axis();
    return rigid(rotation(n[0].item<double>(), n[1].item<double>(), n[2].item<double>(), angle),
                 at::tensor({translation[0], translation[1], translation[2]}, at::kDouble));
  }
  // (w, x, y, z) = (cos(angle / 2), sin(angle / 2) n).
  std::vector<double> quaternion() const {
    const at::Tensor n = unit_axis() * std::sin(angle / 2);
    return {std::cos(angle / 2), n[0].item<double>(), n[1].item<double>(), n[2].item<double>()};
  }
};

struct NuScenesMetadata {
  // The sensors of scene-0001 in sensor.json's order; scene-0002's are the same sensors moved by
  // kSecondSceneShift and with focal lengths 10 larger (a re-calibration).
  std::vector<NuScenesSensor> sensors = {
      // About (0.5, -0.5, 0.5, -0.5): camera z (forward) -> ego x, camera x -> ego -y, as
      // nuScenes' CAM_FRONT.
      {"CAM_FRONT",
       "camera",
       {-1, 1, -1},
       2 * M_PI / 3,
       {1.70, 0.02, 1.51},
       {1266.4, 1266.4, 816.27, 491.51},
       {1600, 900}},
      {"CAM_FRONT_RIGHT",
       "camera",
       {0.3, -0.4, 0.85},
       2.1,
       {1.55, -0.49, 1.50},
       {1260.8, 1260.8, 807.97, 495.33},
       {1600, 900}},
      {"CAM_BACK_RIGHT",
       "camera",
       {-0.7, 0.2, 0.3},
       1.4,
       {1.05, -0.48, 1.59},
       {1256.7, 1256.7, 817.79, 451.95},
       {1600, 900}},
      {"CAM_BACK",
       "camera",
       {0.1, 0.9, -0.2},
       2.9,
       {0.05, -0.01, 1.61},
       {809.2, 809.2, 829.22, 481.77},
       {1600, 900}},
      {"CAM_BACK_LEFT",
       "camera",
       {0.5, 0.5, 0.5},
       0.8,
       {1.04, 0.48, 1.56},
       {1256.7, 1257.1, 792.11, 492.78},
       {1440, 810}},
      {"CAM_FRONT_LEFT",
       "camera",
       {-0.2, -0.6, 0.4},
       1.9,
       {1.52, 0.49, 1.51},
       {1272.6, 1272.6, 826.62, 479.75},
       {1600, 900}},
      {"LIDAR_TOP", "lidar", {0.01, -0.02, 1}, -1.56, {0.94, 0.0, 1.84}, {}, {}},
      {"RADAR_FRONT", "radar", {0, 0, 1}, 0.01, {3.41, 0.0, 0.5}, {}, {}},
  };
  static constexpr double kSecondSceneShift = 0.25;

  // The sensor `channel` as calibrated in scene `scene` (0: scene-0001, 1: scene-0002).
  NuScenesSensor sensor(const std::string& channel, int scene) const {
    for (NuScenesSensor sensor : sensors)
      if (sensor.channel == channel) {
        if (scene == 1) {
          for (double& t : sensor.translation) t += kSecondSceneShift;
          sensor.intrinsic[0] += 10;
          sensor.intrinsic[1] += 10;
          sensor.angle += 0.3;
        }
        return sensor;
      }
    ADD_FAILURE() << "no sensor " << channel;
    return sensors.front();
  }

  static nlohmann::json calibrated(const NuScenesSensor& sensor, const std::string& token) {
    nlohmann::json intrinsic = nlohmann::json::array();
    if (sensor.modality == "camera")
      intrinsic = {{sensor.intrinsic[0], 0.0, sensor.intrinsic[2]},
                   {0.0, sensor.intrinsic[1], sensor.intrinsic[3]},
                   {0.0, 0.0, 1.0}};
    return {{"token", token},
            {"sensor_token", "sensor_" + sensor.channel},
            {"translation", sensor.translation},
            {"rotation", sensor.quaternion()},
            {"camera_intrinsic", intrinsic}};
  }

  // The tables, each a JSON array, by file name.
  std::vector<std::pair<std::string, nlohmann::json>> tables() const {
    using json = nlohmann::json;
    json scene = json::array(), sample = json::array(), sample_data = json::array();
    json calibrated_sensor = json::array(), sensor_table = json::array();
    for (const NuScenesSensor& s : sensors)
      sensor_table.push_back(
          {{"token", "sensor_" + s.channel}, {"channel", s.channel}, {"modality", s.modality}});
    for (int index = 0; index < 2; ++index) {
      const std::string id = std::to_string(index + 1);
      scene.push_back({{"token", "scene_" + id},
                       {"name", "scene-000" + id},
                       {"description", "test scene"},
                       {"log_token", "log"},
                       {"nbr_samples", 2},
                       {"first_sample_token", "sample_" + id + "a"},
                       {"last_sample_token", "sample_" + id + "b"}});
      for (const std::string part : {"a", "b"})
        sample.push_back({{"token", "sample_" + id + part},
                          {"timestamp", 1000 * index},
                          {"scene_token", "scene_" + id},
                          {"prev", part == "a" ? "" : "sample_" + id + "a"},
                          {"next", part == "a" ? "sample_" + id + "b" : ""}});
      for (const NuScenesSensor& base : sensors) {
        const NuScenesSensor s = sensor(base.channel, index);
        const std::string calibration = "calibration_" + id + "_" + s.channel;
        calibrated_sensor.push_back(calibrated(s, calibration));
        // Key frames of both samples; a sweep (not a key frame) of the first sample with the
        // other scene's calibration, which the import must not pick.
        for (const std::string part : {"a", "b", "sweep"}) {
          const std::string other = "calibration_" + std::to_string(2 - index) + "_" + s.channel;
          const bool key_frame = part != "sweep";
          sample_data.push_back({{"token", "data_" + id + part + "_" + s.channel},
                                 {"sample_token", "sample_" + id + (key_frame ? part : "a")},
                                 {"ego_pose_token", "pose"},
                                 {"calibrated_sensor_token", key_frame ? calibration : other},
                                 {"filename", "samples/" + s.channel + "/" + id + part},
                                 {"fileformat", s.modality == "camera" ? "jpg" : "pcd"},
                                 {"width", s.modality == "camera" ? s.size[0] : 0},
                                 {"height", s.modality == "camera" ? s.size[1] : 0},
                                 {"timestamp", 1000 * index},
                                 {"is_key_frame", key_frame},
                                 {"prev", ""},
                                 {"next", ""}});
        }
      }
    }
    return {{"scene.json", scene},
            {"sample.json", sample},
            {"sample_data.json", sample_data},
            {"calibrated_sensor.json", calibrated_sensor},
            {"sensor.json", sensor_table}};
  }

  // Writes the tables into `folder` (a v1.0-* folder).
  void write(const std::filesystem::path& folder) const {
    for (const auto& [name, table] : tables()) write_text(folder / name, table.dump(1));
  }
};

}  // namespace omnipoint::test
