#include "omnipoint/data/synth/rig_render.h"

#include <ATen/ATen.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "omnipoint/data/synth/camera_path.h"
#include "omnipoint/data/synth/kitti_raw_drive.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::data::synth {
namespace {

// A scene pose from a (4, 4) world-from-frame matrix; yaw, pitch and roll read back in
// make_pose's convention (R = Rz(yaw) · level · Rx(pitch) · Rz(roll)) for meta.json.
Pose pose_of(const at::Tensor& world_from) {
  const at::Tensor m = world_from.to(at::kDouble).contiguous();
  const double* p = m.data_ptr<double>();
  Pose pose;
  pose.position = {p[3], p[7], p[11]};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) pose.rotation[i][j] = p[4 * i + j];
  const auto& r = pose.rotation;
  pose.pitch = std::asin(std::max(-1.0, std::min(1.0, r[2][2])));
  pose.yaw = std::atan2(-r[0][2], r[1][2]);
  pose.roll = std::atan2(-r[2][0], -r[2][1]);
  return pose;
}

at::Tensor matrix_of(const Pose& pose) {
  at::Tensor m = at::eye(4, at::kDouble);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[i][j] = pose.rotation[i][j];
    m[i][3] = pose.position[i];
  }
  return m;
}

// Points (N, 3) through a (4, 4) pose.
at::Tensor transform(const at::Tensor& m, const at::Tensor& points) {
  return points.matmul(m.slice(0, 0, 3).slice(1, 0, 3).t()) + m.slice(0, 0, 3).select(1, 3);
}

}  // namespace

BodyAxes parse_body_axes(const std::string& name) {
  if (name == "camera") return BodyAxes::kCamera;
  if (name == "vehicle") return BodyAxes::kVehicle;
  throw std::invalid_argument("--body-axes " + name + ": expected camera or vehicle");
}

void RigRenderOptions::Check() const {
  if (!std::isfinite(yaw)) throw std::invalid_argument("--yaw: expected a finite angle");
  if (lidar) check_lidar(lidar_pattern, lidar_range);
}

at::Tensor world_from_body(const Scene& scene, BodyAxes axes, double yaw) {
  const Pose& view = scene.pose;
  at::Tensor pose = matrix_of(make_pose(view.position, view.yaw + yaw, view.pitch, view.roll));
  if (axes == BodyAxes::kVehicle) {
    at::Tensor camera_from_vehicle = at::eye(4, at::kDouble);
    camera_from_vehicle.slice(0, 0, 3).slice(1, 0, 3).copy_(camera_from_velodyne_axes());
    pose = pose.matmul(camera_from_vehicle);
  }
  return pose;
}

RigRender render_rig(const Scene& scene, const io::Rig& rig, const at::Tensor& world_from_body,
                     const RigRenderOptions& options) {
  options.Check();
  if (options.lidar && !rig.lidar)
    throw std::invalid_argument("--lidar: the rig file has no lidar (body_from_lidar)");
  RigRender result;
  result.world_from_body = world_from_body.to(at::kDouble);
  const at::Tensor body_from_world = at::linalg_inv(result.world_from_body);
  const auto cpu = [](const at::Tensor& t) { return t.to(at::kCPU).contiguous(); };
  for (const io::RigCamera& camera : rig.cameras) {
    const at::Tensor world_from_camera = result.world_from_body.matmul(camera.body_from_camera);
    Scene placed = scene;
    placed.pose = pose_of(world_from_camera);
    // Float64 rays: the surface points reach the body frame exactly.
    const camera::Rays rays =
        camera.camera.ray_map(at::TensorOptions().dtype(at::kDouble).device(options.synth.device));
    const Render render = render_scene(placed, rays.rays, rays.valid, options.synth.render);
    const at::Tensor points = cpu(rays.rays) * cpu(render.distance).unsqueeze(-1);
    const at::Tensor body_points =
        transform(body_from_world, transform(world_from_camera, points.view({-1, 3})))
            .view(points.sizes()) *
        cpu(render.mask).unsqueeze(-1);
    Sample sample{camera.camera, cpu(render.image).to(at::kFloat) / 255.0,
                  cpu(render.distance).to(at::kFloat), cpu(render.mask), true};
    sample.world_from_camera = world_from_camera;
    result.cameras.push_back(
        {camera.name,
         SynthSample{std::move(sample), cpu(render.depth).to(at::kFloat),
                     cpu(rays.rays).to(at::kFloat), cpu(render.normals).to(at::kFloat), placed},
         body_points});
  }
  if (options.lidar) {
    const at::Tensor world_from_lidar = result.world_from_body.matmul(rig.lidar->body_from_lidar);
    Scene placed = scene;
    placed.pose = pose_of(world_from_lidar);
    RenderOptions ranges;  // ranges only: no shading rays
    ranges.shadows = false;
    ranges.ambient_occlusion = false;
    ranges.max_distance = options.lidar_range;
    const at::Tensor beams = lidar_beam_directions(options.lidar_pattern);
    const Render returns =
        render_scene(placed, beams, at::ones({beams.size(0), beams.size(1)}, at::kBool), ranges);
    const at::Tensor hit = returns.mask.reshape({-1});
    result.lidar_points =
        (beams.reshape({-1, 3}) * returns.distance.reshape({-1, 1})).index({hit}).contiguous();
  }
  return result;
}

void write_lidar_sweep(const std::string& path, const at::Tensor& points,
                       int64_t floats_per_point) {
  if (floats_per_point < 3)
    throw std::invalid_argument(path + ": a sweep needs at least x, y, z per point");
  const int64_t n = points.size(0);
  at::Tensor records = at::zeros({n, floats_per_point}, at::kFloat);
  records.slice(1, 0, 3).copy_(points.to(at::kFloat));
  if (floats_per_point > 3) records.select(1, 3).fill_(0.5);
  records = records.contiguous();
  io::write_file_atomically(path, [&](std::ostream& out) {
    out.write(static_cast<const char*>(records.data_ptr()),
              static_cast<std::streamsize>(records.numel() * sizeof(float)));
  });
}

void RigFramesOptions::Check() const {
  if (rig.empty()) throw std::invalid_argument("--rig: no rig file given");
  if (frames < 1 || frames > 1000000)
    throw std::invalid_argument("--count " + std::to_string(frames) +
                                ": expected 1 to 1000000 frames");
  render.Check();
  if (path) check_path_motion(path_step, path_yaw_deg);
}

RigFramesSummary write_rig_frames(const std::string& out, const RigFramesOptions& options,
                                  const std::function<void(const std::string&)>& written) {
  namespace fs = std::filesystem;
  options.Check();
  const io::Rig rig = io::read_rig(options.rig);
  if (options.render.lidar && !rig.lidar)
    throw std::invalid_argument("--lidar: " + options.rig +
                                " has no lidar (body_from_lidar) to cast the sweep from");
  const fs::path root(out);
  fs::create_directories(root);
  io::write_rig((root / "rig.json").string(), rig);
  RigFramesSummary summary;
  for (int64_t k = 0; k < options.frames; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "%06lld", static_cast<long long>(k));
    summary.frames.emplace_back(name);
    const fs::path frame = root / "frames" / name;
    if (fs::is_directory(frame)) {
      ++summary.kept;
      continue;
    }
    const Scene scene = make_scene(
        options.scene, options.path ? options.seed : options.seed + static_cast<std::uint64_t>(k));
    Scene viewpoint = scene;  // where the body stands
    if (options.path)
      viewpoint.pose = camera_path_pose(scene.pose, k, options.path_step, options.path_yaw_deg);
    const RigRender render = render_rig(
        scene, rig, world_from_body(viewpoint, options.render.body_axes, options.render.yaw),
        options.render);
    io::StagedFolder truth(root / "truth" / name);
    for (const RigCameraRender& camera : render.cameras)
      write_synth_sample((truth.path() / camera.name).string(), camera.synth);
    truth.commit();
    io::StagedFolder images(frame);
    for (const RigCameraRender& camera : render.cameras)
      io::write_image_png((images.path() / (camera.name + ".png")).string(),
                          (camera.synth.sample.image * 255).round().to(at::kByte));
    if (render.lidar_points.defined()) {
      write_lidar_sweep((images.path() / "lidar.bin").string(), render.lidar_points,
                        rig.lidar->floats_per_point);
      summary.lidar_points += render.lidar_points.size(0);
    }
    images.commit();
    ++summary.rendered;
    if (written) written(frame.string());
  }
  return summary;
}

}  // namespace omnipoint::data::synth
