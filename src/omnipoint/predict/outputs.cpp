#include "omnipoint/predict/outputs.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>
#include <ATen/Parallel.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <functional>
#include <mutex>
#include <ostream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "omnipoint/camera/camera_info.h"
#include "omnipoint/geometry/colormap.h"
#include "omnipoint/geometry/grid_surface.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/glb.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/io/staged_folder.h"
#include "omnipoint/predict/colmap_scene.h"
#include "omnipoint/predict/preview.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::predict {

namespace fs = std::filesystem;

namespace {

nlohmann::json summary(const Prediction& p) {
  nlohmann::json json;
  if (p.fitted_camera) {
    const camera::FieldOfView fov = camera::field_of_view(*p.fitted_camera);
    json["camera"] = nlohmann::json::parse(p.fitted_camera->to_json());
    json["camera_source"] = camera_source_name(camera_source_of(p));
    if (p.fit_residual)
      json["fit_residual_deg"] = {{"median", p.fit_residual->median_deg},
                                  {"max", p.fit_residual->max_deg}};
    if (p.camera_agreement)
      json["camera_vs_network_rays_deg"] = {{"mean", p.camera_agreement->mean_deg},
                                            {"median", p.camera_agreement->median_deg},
                                            {"max", p.camera_agreement->max_deg}};
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
  json["edge_filter"] = {{"rtol", p.edge_rtol}, {"removed_pixels", p.edge_pixels_removed}};
  json["precision"] = model::precision_name(p.precision);
  json["notes"] = p.notes;
  json["warnings"] = p.warnings;
  json["timing_ms"] = {{"prepare", p.timing.prepare_ms},
                       {"network", p.timing.network_ms},
                       {"alignment", p.timing.alignment_ms},
                       {"camera_fit", p.timing.camera_fit_ms}};
  return json;
}

void write_text(const fs::path& path, const std::string& text) {
  io::write_file_atomically(path.string(), [&](std::ostream& out) { out << text; });
}

// The groups of parse_output_list, in the order its message lists them.
const std::vector<std::pair<std::string, std::vector<std::string>>>& output_groups() {
  static const std::vector<std::pair<std::string, std::vector<std::string>>> groups = {
      {"ply", {"points.ply"}},
      {"glb", {"points.glb"}},
      {"npy", {"points.npy", "distance.npy", "depth.npy", "rays.npy", "normals.npy"}},
      {"depth", {"depth.png", "distance.png"}},
      {"mask", {"mask.png"}},
      {"vis", {"depth_vis.png"}},
      {"preview", {"preview.png"}},
      {"image", {"image.png"}},
      {"png",
       {"mask.png", "depth.png", "distance.png", "depth_vis.png", "preview.png", "image.png"}},
      {"mesh", {"mesh.glb"}},
      {"camera", {"camera.json"}},
  };
  return groups;
}

// A 16-bit PNG of `values` (H, W) metres at `units_per_metre`: 0 outside `valid` and where
// the rounded value is not in [1, 65535] (counted).
struct Png16 {
  at::Tensor codes;  // (H, W) int32
  int64_t out_of_range = 0;
};
Png16 quantize_png16(const at::Tensor& values, const at::Tensor& valid, double units_per_metre) {
  // One pass in double over the map as it is (a chain of full-size double tensors took ~1 s
  // at 12 MP, a double copy of the map ~0.1 s).
  const bool native = values.scalar_type() == at::kFloat || values.scalar_type() == at::kDouble;
  const at::Tensor metres =
      values.to(at::kCPU, native ? values.scalar_type() : at::kDouble).contiguous();
  const at::Tensor shown = valid.to(at::kCPU).contiguous();
  Png16 png{at::empty(metres.sizes(), at::kInt)};
  const bool* ok = shown.data_ptr<bool>();
  int32_t* code = png.codes.data_ptr<int32_t>();
  AT_DISPATCH_FLOATING_TYPES(metres.scalar_type(), "quantize_png16", [&] {
    const scalar_t* value = metres.data_ptr<scalar_t>();
    for (int64_t i = 0; i < metres.numel(); ++i) {
      const double rounded = std::nearbyint(static_cast<double>(value[i]) * units_per_metre);
      const bool fits = ok[i] && rounded >= 1 && rounded <= 65535;
      code[i] = fits ? static_cast<int32_t>(rounded) : 0;
      png.out_of_range += ok[i] && !fits;
    }
  });
  return png;
}

constexpr double kDepthPngUnitsPerMetre = 1000;    // millimetres
constexpr double kDistancePngUnitsPerMetre = 256;  // KITTI's depth-PNG scale

// camera.json's record of a 16-bit PNG's encoding.
nlohmann::json png16_record(const char* quantity, double units_per_metre, const Png16& png) {
  return {{"quantity", quantity},
          {"scale_m_per_unit", 1 / units_per_metre},
          {"max_m", 65535 / units_per_metre},
          {"zero", "invalid or not representable"},
          {"out_of_range_pixels", png.out_of_range}};
}

double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// Runs `jobs` on LibTorch's intra-op threads, each thread taking the next job in turn until
// none is left or one has failed; then rethrows the first failure. Writing is mostly
// single-threaded (encoders, the kernel copying into the page cache), so a job per core beats
// one job at a time with parallel loops inside: within the region, LibTorch's own parallel
// loops run on the calling thread.
void write_concurrently(const std::vector<std::function<void()>>& jobs) {
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto work = [&] {
    for (size_t job = next++; job < jobs.size() && !failed; job = next++) {
      try {
        jobs[job]();
      } catch (...) {
        const std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
        failed = true;
      }
    }
  };
  const auto threads = static_cast<int64_t>(
      std::min<size_t>(jobs.size(), static_cast<size_t>(std::max(1, at::get_num_threads()))));
  if (threads <= 1)
    work();
  else
    util::parallel_for(0, threads, 1, [&](int64_t begin, int64_t end) {
      for (int64_t thread = begin; thread < end; ++thread) work();
    });
  if (failure) std::rethrow_exception(failure);
}

}  // namespace

std::set<std::string> all_output_files() {
  std::set<std::string> files;
  for (const auto& [name, members] : output_groups()) files.insert(members.begin(), members.end());
  return files;
}

std::set<std::string> default_output_files() {
  std::set<std::string> files = all_output_files();
  files.erase("mesh.glb");
  return files;
}

std::set<std::string> parse_output_list(const std::string& list) {
  const std::set<std::string> every_file = all_output_files();
  std::set<std::string> files = {"camera.json"};
  std::string names;  // the valid names, for the message
  for (const auto& [name, members] : output_groups()) names += name + ", ";
  names += "default, all, or a file name (";
  for (const std::string& file : every_file)
    names += file + (file == *every_file.rbegin() ? ")" : ", ");
  size_t begin = 0;
  while (true) {
    const size_t comma = list.find(',', begin);
    const std::string name =
        list.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin);
    const auto group = std::find_if(output_groups().begin(), output_groups().end(),
                                    [&](const auto& entry) { return entry.first == name; });
    if (group != output_groups().end()) {
      files.insert(group->second.begin(), group->second.end());
    } else if (name == "default" || name == "all") {
      const std::set<std::string> chosen = name == "all" ? every_file : default_output_files();
      files.insert(chosen.begin(), chosen.end());
    } else if (every_file.count(name) != 0) {
      files.insert(name);
    } else {
      throw std::invalid_argument(
          "outputs: " +
          (name.empty() ? std::string("an empty name") : "unknown name \"" + name + "\"") +
          " in \"" + list + "\"; valid: " + names);
    }
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  return files;
}

std::string prediction_summary_json(const Prediction& prediction) {
  return summary(prediction).dump(2);
}

double write_prediction_outputs(const std::string& folder, const at::Tensor& image,
                                const Prediction& p, const OutputOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int64_t height = p.mask.size(0), width = p.mask.size(1);
  if (image.dim() != 3 || image.size(0) != height || image.size(1) != width || image.size(2) != 3)
    throw std::invalid_argument("outputs: the image is " + c10::str(image.sizes()) +
                                ", the prediction " + std::to_string(height) + "x" +
                                std::to_string(width));
  for (const std::string& file : options.files)
    if (file != "camera.json" && all_output_files().count(file) == 0)
      throw std::invalid_argument("outputs: unknown file \"" + file + "\"");
  const auto wanted = [&](const char* file) { return options.files.count(file) != 0; };
  const at::Tensor rgb =
      image.scalar_type() == at::kByte
          ? image.to(at::kCPU)
          : (image.to(at::kCPU, at::kFloat).clamp(0, 1) * 255).round().to(at::kByte);

  io::StagedFolder staged(folder);
  const fs::path& staging = staged.path();
  nlohmann::json json = summary(p);
  if (!options.camera_json_extra.empty())
    json.update(nlohmann::json::parse(options.camera_json_extra));
  nlohmann::json file_ms = nlohmann::json::object();
  std::mutex json_mutex;  // the writers run concurrently; json and file_ms are shared
  const auto record = [&](const auto& update) {
    const std::lock_guard<std::mutex> lock(json_mutex);
    update();
  };
  // The files are independent, so they are written concurrently (write_concurrently), each
  // computing what only it needs. Queued roughly longest first, so that the last to finish
  // is a short one.
  std::vector<std::function<void()>> jobs;
  const auto add_job = [&](const char* file, auto write) {
    jobs.push_back([&, file, write] {
      const auto file_start = std::chrono::steady_clock::now();
      write((staging / file).string());
      const double ms = ms_since(file_start);
      record([&] { file_ms[file] = ms; });
    });
  };
  const auto produce = [&](const char* file, auto write) {
    if (wanted(file)) add_job(file, write);
  };
  // The valid points, shared by the PLY, the GLB, the preview and the world PLY: made by
  // whichever of them starts first.
  geometry::PointCloud valid_cloud;
  std::once_flag cloud_made;
  const auto cloud = [&]() -> const geometry::PointCloud& {
    std::call_once(cloud_made, [&] {
      const auto cloud_start = std::chrono::steady_clock::now();
      valid_cloud = geometry::valid_points(geometry::make_point_cloud(p.points, rgb, p.mask));
      const double ms = ms_since(cloud_start);
      record([&] { json["timing_ms"]["valid_points"] = ms; });
    });
    return valid_cloud;
  };
  produce("mesh.glb", [&](const std::string& path) {
    const at::Tensor kept =
        p.mask & ~geometry::depth_edge_mask(p.distance, p.mask, options.mesh_edge_rtol);
    const geometry::GridMesh mesh = geometry::grid_mesh(p.points, kept);
    io::write_glb_mesh(path, mesh.vertices, rgb.reshape({-1, 3}).index_select(0, mesh.pixels),
                       mesh.faces);
    record([&] {
      json["mesh"] = {{"vertices", mesh.vertices.size(0)},
                      {"triangles", mesh.faces.size(0)},
                      {"edge_rtol", options.mesh_edge_rtol}};
    });
  });
  produce("normals.npy", [&](const std::string& path) {
    io::write_npy(path, geometry::normals_from_point_map(p.points, p.mask).normals.to(at::kFloat));
  });
  produce("points.ply",
          [&](const std::string& path) { io::write_ply(path, cloud().points, cloud().colors); });
  const bool world = options.camera_from_world.defined();
  if (world) {
    const at::Tensor pose = options.camera_from_world.to(at::kCPU, at::kDouble).contiguous();
    json["camera_from_world"] =
        std::vector<double>(pose.data_ptr<double>(), pose.data_ptr<double>() + 16);
    add_job("points_world.ply", [&](const std::string& path) {
      io::write_ply(path, world_points(cloud().points, options.camera_from_world), cloud().colors);
    });
  }
  produce("points.glb", [&](const std::string& path) {
    io::write_glb_points(path, cloud().points, cloud().colors);
  });
  produce("points.npy",
          [&](const std::string& path) { io::write_npy(path, p.points.to(at::kFloat)); });
  produce("rays.npy", [&](const std::string& path) { io::write_npy(path, p.rays.to(at::kFloat)); });
  produce("depth_vis.png", [&](const std::string& path) {
    io::write_image_png(path, geometry::colorize_depth(p.distance, p.mask));
  });
  produce("image.png", [&](const std::string& path) { io::write_image_png(path, rgb); });
  produce("preview.png", [&](const std::string& path) {
    io::write_image_png(path, render_preview(cloud().points, cloud().colors));
  });
  produce("depth.png", [&](const std::string& path) {
    const Png16 png = quantize_png16(p.depth, p.mask & (p.depth > 0), kDepthPngUnitsPerMetre);
    io::write_image_png(path, png.codes);
    const int64_t behind = (p.mask & (p.depth <= 0)).sum().item<int64_t>();
    record([&] {
      json["depth_png"] = png16_record("planar depth z", kDepthPngUnitsPerMetre, png);
      json["depth_png"]["behind_camera_pixels"] = behind;
    });
  });
  produce("distance.png", [&](const std::string& path) {
    const Png16 png = quantize_png16(p.distance, p.mask, kDistancePngUnitsPerMetre);
    io::write_image_png(path, png.codes);
    record([&] {
      json["distance_png"] = png16_record("radial distance", kDistancePngUnitsPerMetre, png);
    });
  });
  produce("distance.npy",
          [&](const std::string& path) { io::write_npy(path, p.distance.to(at::kFloat)); });
  produce("depth.npy",
          [&](const std::string& path) { io::write_npy(path, p.depth.to(at::kFloat)); });
  produce("mask.png", [&](const std::string& path) { io::write_image_png(path, p.mask); });
  write_concurrently(jobs);
  std::set<std::string> written = options.files;
  written.insert("camera.json");
  if (world) written.insert("points_world.ply");
  json["files"] = written;
  json["timing_ms"]["files"] = file_ms;  // part of writing
  json["timing_ms"]["writing"] = ms_since(start);
  write_text(staging / "camera.json", json.dump(2) + "\n");
  if (p.fitted_camera)
    write_text(staging / "cameras.txt", camera::to_cameras_txt(*p.fitted_camera));
  staged.commit();
  return ms_since(start);
}

}  // namespace omnipoint::predict
