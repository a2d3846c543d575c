#include "omnipoint/data/synth/kitti_raw_drive.h"

#include <ATen/ATen.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "omnipoint/data/formats/lidar_labels.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::data::synth {
namespace {

namespace fs = std::filesystem;

// KITTI's rectified baselines t_X of P_rect_0X = K [I | t_X] (metres, camera 0's frame).
const double kBaseline[4] = {0.0, -0.54, 0.06, -0.48};

// The camera frame (x right, y down, z forward) from KITTI's Velodyne frame (x forward, y left,
// z up), row-major.
const double kCameraFromVelodyne[9] = {0, -1, 0, 0, 0, -1, 1, 0, 0};

// "%e" numbers, space-separated: the devkits' calibration format.
std::string numbers(const std::vector<double>& values) {
  std::string text;
  for (const double value : values) {
    char number[32];
    std::snprintf(number, sizeof number, "%e", value);
    text += (text.empty() ? "" : " ") + std::string(number);
  }
  return text;
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out.flush()) throw std::runtime_error(path.string() + ": cannot write it");
}

std::string cam_to_cam_text(const camera::Camera& camera) {
  const std::vector<double>& p = camera.params();  // fx fy cx cy
  // The devkit's integer-centre principal point: its pixel i is centred at u = i.
  const double fx = p[0], fy = p[1], u0 = p[2] - 0.5, v0 = p[3] - 0.5;
  const std::vector<double> k = {fx, 0, u0, 0, fy, v0, 0, 0, 1};
  const std::vector<double> identity = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::vector<double> size = {static_cast<double>(camera.width()),
                                    static_cast<double>(camera.height())};
  std::string text = "calib_time: 01-Jan-2000 00:00:00\ncorner_dist: 9.950000e-02\n";
  for (int c = 0; c < 4; ++c) {
    const std::string id = "0" + std::to_string(c);
    const std::vector<double> t = {kBaseline[c], 0, 0};
    text += "S_" + id + ": " + numbers(size) + "\n";
    text += "K_" + id + ": " + numbers(k) + "\n";
    text += "D_" + id + ": " + numbers({0, 0, 0, 0, 0}) + "\n";
    text += "R_" + id + ": " + numbers(identity) + "\n";
    text += "T_" + id + ": " + numbers(t) + "\n";
    text += "S_rect_" + id + ": " + numbers(size) + "\n";
    text += "R_rect_" + id + ": " + numbers(identity) + "\n";
    text +=
        "P_rect_" + id + ": " + numbers({fx, 0, u0, fx * t[0], 0, fy, v0, 0, 0, 0, 1, 0}) + "\n";
  }
  return text;
}

// Velodyne -> unrectified camera 0: the axes, and the sensor at image_02's centre (T = -t_02).
std::string velo_to_cam_text() {
  return "calib_time: 01-Jan-2000 00:00:00\nR: " +
         numbers(std::vector<double>(kCameraFromVelodyne, kCameraFromVelodyne + 9)) +
         "\nT: " + numbers({-kBaseline[2], 0, 0}) +
         "\ndelta_f: 0.000000e+00 0.000000e+00\ndelta_c: 0.000000e+00 0.000000e+00\n";
}

// The beams' unit directions (beams, azimuth_steps, 3) in the camera frame.
at::Tensor beam_rays(const geometry::LidarPattern& pattern) {
  return at::matmul(lidar_beam_directions(pattern), camera_from_velodyne_axes().t()).contiguous();
}

}  // namespace

void KittiRawDriveOptions::Check() const {
  if (camera.model_name() != "PINHOLE")
    throw std::invalid_argument("--camera " + camera.to_spec() +
                                ": the KITTI raw layout holds rectified PINHOLE images");
  if (frames < 1) throw std::invalid_argument("--count: expected at least 1 training frame");
  if (held_out < 0) throw std::invalid_argument("--held-out: expected 0 or more frames");
  if (frames + held_out > 10000000000LL)
    throw std::invalid_argument("--count: KITTI's frame names hold at most 10^10 frames");
  check_lidar(lidar, lidar_range);
}

at::Tensor camera_from_velodyne_axes() {
  return at::tensor(at::ArrayRef<double>(kCameraFromVelodyne, 9)).view({3, 3});
}

at::Tensor lidar_beam_directions(const geometry::LidarPattern& pattern) {
  const double step = pattern.beams > 1 ? (pattern.max_elevation_deg - pattern.min_elevation_deg) /
                                              static_cast<double>(pattern.beams - 1)
                                        : 0.0;
  const at::Tensor elevation =
      (at::arange(pattern.beams, at::kDouble) * step + pattern.min_elevation_deg) * (M_PI / 180.0);
  const at::Tensor azimuth = at::arange(pattern.azimuth_steps, at::kDouble) *
                             (2.0 * M_PI / static_cast<double>(pattern.azimuth_steps));
  const auto grid = at::meshgrid({elevation, azimuth}, "ij");
  const at::Tensor e = grid[0], a = grid[1];
  return at::stack({e.cos() * a.cos(), e.cos() * a.sin(), e.sin()}, -1);
}

void check_lidar(const geometry::LidarPattern& p, double range) {
  if (p.beams < 1 || p.azimuth_steps < 1 || !std::isfinite(p.min_elevation_deg) ||
      !std::isfinite(p.max_elevation_deg) || p.min_elevation_deg > p.max_elevation_deg ||
      p.min_elevation_deg < -90 || p.max_elevation_deg > 90)
    throw std::invalid_argument(
        "LiDAR: expected beams >= 1, azimuth steps >= 1 and -90 <= min <= max <= 90 degrees of "
        "elevation");
  if (!(range > 0) || !std::isfinite(range))
    throw std::invalid_argument("LiDAR range: expected a positive number of metres");
}

KittiRawDriveSummary write_kitti_raw_drive(const std::string& root,
                                           const KittiRawDriveOptions& options) {
  options.Check();
  if (fs::exists(root) && !(fs::is_directory(root) && fs::is_empty(root)))
    throw std::invalid_argument(root +
                                ": exists and is not an empty folder (a KITTI raw root "
                                "is written whole)");
  io::StagedFolder staged{fs::path(root)};
  const fs::path date = staged.path() / kSynthDriveDate;
  fs::create_directories(date);
  write_text(date / "calib_cam_to_cam.txt", cam_to_cam_text(options.camera));
  write_text(date / "calib_velo_to_cam.txt", velo_to_cam_text());

  const at::Tensor rays = beam_rays(options.lidar);
  const at::Tensor valid = at::ones({rays.size(0), rays.size(1)}, at::kBool);
  RenderOptions lidar_render;  // ranges only: no shading rays
  lidar_render.shadows = false;
  lidar_render.ambient_occlusion = false;
  lidar_render.max_distance = options.lidar_range;
  const at::Tensor camera_from_velodyne = camera_from_velodyne_axes();

  KittiRawDriveSummary summary;
  double density_sum = 0;
  const int64_t total = options.frames + options.held_out;
  for (int64_t i = 0; i < total; ++i) {
    const bool training = i < options.frames;
    const int64_t frame = training ? i : i - options.frames;
    const std::string drive =
        std::string(kSynthDriveDate) + (training ? "_drive_0001_sync" : "_drive_0002_sync");
    char stem[32];
    std::snprintf(stem, sizeof stem, "%010lld", static_cast<long long>(frame));
    const SynthSample sample = synthesize(options.scene, options.seed + static_cast<uint64_t>(i),
                                          options.camera, options.synth);
    const fs::path images = date / drive / "image_02" / "data";
    const fs::path sweeps = date / drive / "velodyne_points" / "data";
    fs::create_directories(images);
    fs::create_directories(sweeps);
    io::write_image_png((images / (std::string(stem) + ".png")).string(), sample.sample.image);

    const Render returns = render_scene(sample.scene, rays, valid, lidar_render);
    const at::Tensor hit = returns.mask.reshape({-1});
    const at::Tensor camera_points =
        (rays.reshape({-1, 3}) * returns.distance.reshape({-1, 1})).index({hit});
    // Rows x^T · R = (R^T x)^T: the points in the Velodyne frame.
    const at::Tensor velodyne_points = at::matmul(camera_points, camera_from_velodyne);
    const at::Tensor records =
        at::cat({velodyne_points, at::full({velodyne_points.size(0), 1}, 0.5, at::kDouble)}, 1)
            .to(at::kFloat)
            .contiguous();
    {
      const fs::path sweep = sweeps / (std::string(stem) + ".bin");
      std::ofstream out(sweep, std::ios::binary);
      out.write(static_cast<const char*>(records.data_ptr()),
                static_cast<std::streamsize>(records.numel() * sizeof(float)));
      if (!out.flush()) throw std::runtime_error(sweep.string() + ": cannot write it");
    }
    summary.returns += velodyne_points.size(0);
    density_sum +=
        lidar_labels(camera_points, options.camera).mask.to(at::kDouble).mean().item<double>();
    (training ? summary.train_frames : summary.test_frames)
        .push_back(std::string(kSynthDriveDate) + "/" + drive + " " + std::to_string(frame) + " l");
  }
  summary.label_density = density_sum / static_cast<double>(total);
  const auto list = [](const std::vector<std::string>& lines) {
    std::string text;
    for (const std::string& line : lines) text += line + "\n";
    return text;
  };
  write_text(staged.path() / "train_files.txt", list(summary.train_frames));
  if (options.held_out > 0) write_text(staged.path() / "test_files.txt", list(summary.test_frames));
  staged.commit();
  return summary;
}

}  // namespace omnipoint::data::synth
