#include "omnipoint/predict/outputs.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <ostream>
#include <random>
#include <stdexcept>

#include "omnipoint/camera/camera_info.h"
#include "omnipoint/geometry/colormap.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/glb.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/predict/preview.h"

namespace omnipoint::predict {

namespace fs = std::filesystem;

namespace {

nlohmann::json summary(const Prediction& p) {
  nlohmann::json json;
  if (p.fitted_camera) {
    const camera::FieldOfView fov = camera::field_of_view(*p.fitted_camera);
    json["camera"] = nlohmann::json::parse(p.fitted_camera->to_json());
    json["camera_source"] = p.fit_residual ? "fitted" : "given";
    if (p.fit_residual)
      json["fit_residual_deg"] = {{"median", p.fit_residual->median_deg},
                                  {"max", p.fit_residual->max_deg}};
    json["camera_spec"] = p.fitted_camera->to_spec();
    json["cameras_txt_line"] = camera::cameras_txt_line(*p.fitted_camera);
    json["fov_deg"] = {{"horizontal", fov.horizontal_deg},
                       {"vertical", fov.vertical_deg},
                       {"diagonal", fov.diagonal_deg}};
  } else {
    json["camera"] = nullptr;
    if (!p.fit_error.empty()) json["fit_error"] = p.fit_error;
  }
  json["metric_scale"] = p.metric_scale;
  json["sparse_depth"] = {{"samples", p.sparse_samples}, {"alignment_factor", p.alignment_factor}};
  json["valid_pixels"] = p.mask.sum().item<int64_t>();
  json["notes"] = p.notes;
  json["timing_ms"] = {{"prepare", p.timing.prepare_ms},
                       {"network", p.timing.network_ms},
                       {"alignment", p.timing.alignment_ms},
                       {"camera_fit", p.timing.camera_fit_ms}};
  return json;
}

void write_text(const fs::path& path, const std::string& text) {
  io::write_file_atomically(path.string(), [&](std::ostream& out) { out << text; });
}

}  // namespace

std::string prediction_summary_json(const Prediction& prediction) {
  return summary(prediction).dump(2);
}

double write_prediction_outputs(const std::string& folder, const at::Tensor& image,
                                const Prediction& p) {
  const auto start = std::chrono::steady_clock::now();
  const int64_t height = p.mask.size(0), width = p.mask.size(1);
  if (image.dim() != 3 || image.size(0) != height || image.size(1) != width || image.size(2) != 3)
    throw std::invalid_argument("outputs: the image is " + c10::str(image.sizes()) +
                                ", the prediction " + std::to_string(height) + "x" +
                                std::to_string(width));
  const at::Tensor rgb =
      image.scalar_type() == at::kByte
          ? image.to(at::kCPU)
          : (image.to(at::kCPU, at::kFloat).clamp(0, 1) * 255).round().to(at::kByte);

  const fs::path target(folder);
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  fs::create_directories(parent);
  std::random_device random;
  const fs::path staging =
      parent / ("." + target.filename().string() + ".partial-" + std::to_string(random()));
  fs::create_directories(staging);
  try {
    const geometry::PointCloud cloud =
        geometry::valid_points(geometry::make_point_cloud(p.points, rgb, p.mask));
    io::write_ply((staging / "points.ply").string(), cloud.points, cloud.colors);
    io::write_glb_points((staging / "points.glb").string(), cloud.points, cloud.colors);
    io::write_npy((staging / "points.npy").string(), p.points.to(at::kFloat));
    io::write_npy((staging / "distance.npy").string(), p.distance.to(at::kFloat));
    io::write_npy((staging / "depth.npy").string(), p.depth.to(at::kFloat));
    io::write_npy((staging / "rays.npy").string(), p.rays.to(at::kFloat));
    io::write_image_png((staging / "mask.png").string(), p.mask);
    const at::Tensor depth_mm =
        at::where(p.mask & (p.depth > 0), (p.depth * 1000.0).round().clamp(0, 65535),
                  at::zeros_like(p.depth));
    io::write_image_png((staging / "depth.png").string(), depth_mm.to(at::kInt));
    io::write_image_png((staging / "depth_vis.png").string(),
                        geometry::colorize_depth(p.distance, p.mask));
    const auto preview_start = std::chrono::steady_clock::now();
    io::write_image_png((staging / "preview.png").string(),
                        render_preview(cloud.points, cloud.colors));
    const double preview_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - preview_start)
            .count();
    nlohmann::json json = summary(p);
    json["timing_ms"]["preview"] = preview_ms;  // part of writing
    json["timing_ms"]["writing"] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    write_text(staging / "camera.json", json.dump(2) + "\n");
    if (p.fitted_camera)
      write_text(staging / "cameras.txt", camera::to_cameras_txt(*p.fitted_camera));
    fs::remove_all(target);
    fs::rename(staging, target);
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(staging, ignored);
    throw;
  }
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace omnipoint::predict
