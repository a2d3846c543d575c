// omnipoint predict: images (+ camera, + sparse depth, or a COLMAP reconstruction) -> one output
// folder per image (predict/outputs.h). A bad image or sparse-depth file skips that image with
// one line on stderr; inputs that look wrong get a warning line; the run ends with a summary
// that counts both, and a non-zero status when an image failed.
#include <ATen/ATen.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/bundled.h"
#include "cli/commands.h"
#include "cli/device.h"
#include "cli/image_list.h"
#include "cli/progress.h"
#include "cli/threads.h"
#include "cli/view_server.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/io/point_cloud.h"
#include "omnipoint/predict/colmap_scene.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::cli {

namespace {

namespace fs = std::filesystem;

struct PredictCommandOptions {
  std::vector<std::string> inputs;
  std::string camera;
  double fov_deg = 0;
  std::string colmap;
  std::string sparse_depth;
  bool sparse_depth_radial = false;
  double depth_scale = 1000.0;
  std::string lidar_to_camera;
  std::string lidar_format = "kitti";
  std::string model_path;
  std::string out_dir = "predictions";
  int64_t max_size = 0;
  std::string outputs = "default";
  double edge_rtol = predict::kDefaultEdgeRtol;
  int64_t num_tokens = 0;
  std::string fit_model = "auto";
  std::string device = "cpu";
  std::string precision = "auto";
  bool view = false;
  bool cached_writes = false;
  int threads = 0;  // 0: every core
};

// --model, else $OMNIPOINT_MODEL, else the bundled model: installed beside the tool
// (<prefix>/bin/omnipoint -> <prefix>/share/omnipoint/), else in the source tree it was built from.
std::string model_path_or_bundled(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* environment = std::getenv("OMNIPOINT_MODEL");
      environment != nullptr && *environment != '\0')
    return environment;
  return find_bundled(OMNIPOINT_INSTALLED_MODEL, OMNIPOINT_SOURCE_MODEL,
                      "no model given and the bundled one", ": pass a checkpoint with --model FILE")
      .string();
}

// The sparse depth file of one image: the file itself, or in a folder the file with the image's
// path below its input folder (then its stem alone), one of the sparse-depth extensions.
std::optional<fs::path> sparse_depth_file(const std::string& option, const ImageEntry& image) {
  if (!fs::is_directory(option)) return fs::path(option);
  for (const fs::path& stem : {fs::path(option) / fs::path(image.relative).replace_extension(),
                               fs::path(option) / image.path.stem()})
    for (const std::string& ext : predict::sparse_depth_extensions())
      if (fs::path candidate = fs::path(stem) += ext; fs::is_regular_file(candidate))
        return candidate;
  return std::nullopt;
}

// The points of all images in the reconstruction's world frame (OUT/fused.ply).
struct FusedCloud {
  std::vector<at::Tensor> points, colors;
  void add(const predict::Prediction& p, const at::Tensor& image, const at::Tensor& pose) {
    const geometry::PointCloud cloud =
        geometry::valid_points(geometry::make_point_cloud(p.points, image, p.mask));
    points.push_back(predict::world_points(cloud.points, pose));
    colors.push_back(cloud.colors);
  }
};

std::string fixed(double value, int digits) {
  std::ostringstream text;
  text.precision(digits);
  text << value;
  return text.str();
}

void run_predict(const PredictCommandOptions& options) {
  if (!io::image_io_available())
    throw std::runtime_error("this build has no image file I/O (OpenCV)");
  if (options.view && !viewer_available())
    throw std::runtime_error(
        "--view: this omnipoint was built without the viewer "
        "(OMNIPOINT_WITH_VIEWER=OFF)");
  if (!options.camera.empty() && options.fov_deg > 0)
    throw std::invalid_argument("--camera and --fov: give one of them");
  if (!options.colmap.empty() &&
      (!options.camera.empty() || options.fov_deg > 0 || !options.sparse_depth.empty() ||
       !options.lidar_to_camera.empty()))
    throw std::invalid_argument(
        "--colmap brings each image's camera and sparse depth: drop --camera, --fov, "
        "--sparse-depth and --lidar-to-camera");
  const ImageList list = list_images(options.inputs);
  if (list.images.size() > 1 && !options.sparse_depth.empty() &&
      !fs::is_directory(options.sparse_depth))
    throw std::invalid_argument(
        "--sparse-depth " + options.sparse_depth +
        ": one file for several images; pass a folder with a file per image name");
  predict::SparseDepthFileOptions sparse_files;
  sparse_files.depth_png_units_per_metre = options.depth_scale;
  sparse_files.lidar_floats_per_point = io::lidar_floats_per_point(options.lidar_format);
  if (!options.lidar_to_camera.empty())  // once, so a bad file fails before any work
    sparse_files.camera_from_lidar = io::read_rigid_transform(options.lidar_to_camera);

  predict::PredictOptions base;
  // The camera is read with each image's size, which only files without one (UniK3D's JSON)
  // use; a bad camera fails here, on the first image's size, before any work.
  std::map<std::pair<int64_t, int64_t>, camera::Camera> cameras;
  const auto given_camera = [&](int64_t width, int64_t height) {
    auto known = cameras.find({width, height});
    if (known == cameras.end())
      known = cameras
                  .emplace(std::make_pair(width, height),
                           io::read_camera(options.camera, camera::ImageSize{width, height}))
                  .first;
    return known->second;
  };
  if (!options.camera.empty()) {
    at::Tensor first;
    try {
      first = io::read_image(list.images.front().path.string());
    } catch (const std::runtime_error&) {
      // an unreadable first image is reported (and skipped) in the loop
    }
    if (first.defined()) given_camera(first.size(1), first.size(0));
  }
  base.num_tokens = options.num_tokens;
  const at::Device device = parse_device(options.device);
  base.precision = parse_precision(options.precision, device);
  base.fit_model = options.fit_model == "none" ? "" : options.fit_model;
  base.edge_rtol = options.edge_rtol;
  predict::OutputOptions outputs;
  outputs.files = predict::parse_output_list(options.outputs);
  std::optional<predict::ColmapScene> colmap;
  if (!options.colmap.empty()) colmap = predict::ColmapScene::read(options.colmap);
  const Model model = Model::load(model_path_or_bundled(options.model_path), device);

  Progress progress(static_cast<int64_t>(list.images.size()));
  if (list.skipped_files > 0)
    progress.line("omnipoint: note: " + std::to_string(list.skipped_files) +
                  " file(s) in the input folders are not images and were skipped");
  if (colmap)
    progress.line(
        "omnipoint: note: COLMAP's scale is arbitrary: the predictions are aligned to the "
        "reconstruction's points, so they are in its units (not metres) and its world frame");
  FusedCloud fused;
  int64_t failed = 0, warnings = 0;
  for (size_t i = 0; i < list.images.size(); ++i) {
    const ImageEntry& entry = list.images[i];
    progress.start(static_cast<int64_t>(i), entry.relative.string());
    const std::string prefix = progress.prefix();
    const auto warn = [&](const std::string& text) {
      ++warnings;
      progress.line("omnipoint: warning: " + prefix + entry.path.string() + ": " + text);
    };
    try {
      const auto start = std::chrono::steady_clock::now();
      const at::Tensor original = io::read_image(entry.path.string());
      const camera::ImageSize size =
          predict::size_within(original.size(1), original.size(0), options.max_size);
      const at::Tensor image = predict::resize_image(original, size.width, size.height);
      const double decode_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();

      predict::PredictOptions item = base;
      if (!options.camera.empty()) item.camera = given_camera(original.size(1), original.size(0));
      if (options.fov_deg > 0)
        item.camera = camera::centred_pinhole(options.fov_deg, original.size(1), original.size(0));
      const predict::ColmapView* view = nullptr;
      if (colmap) {
        view = colmap->find(entry.relative.generic_string());
        if (view == nullptr) {
          warn(
              "not an image of the COLMAP reconstruction: predicted without its camera and "
              "sparse depth, and left out of fused.ply");
        } else {
          item.camera = view->camera;
          item.sparse_depth = predict::sparse_depth_of(*view);
          item.sparse_depth_is_metric = false;
        }
      } else if (!options.sparse_depth.empty()) {
        if (const auto file = sparse_depth_file(options.sparse_depth, entry)) {
          item.sparse_depth = predict::read_sparse_depth(file->string(), sparse_files);
          if (options.sparse_depth_radial) {
            if (!item.sparse_depth.depth_map.defined())
              throw std::invalid_argument("sparse depth " + file->string() +
                                          ": --sparse-depth-radial applies to depth maps only");
            item.sparse_depth.depth_is_planar = false;
          }
          if (item.sparse_depth.lidar_points.defined() && options.lidar_to_camera.empty())
            warn("the point cloud " + file->string() +
                 " is taken as in the camera frame (no --lidar-to-camera given)");
        } else {
          warn("no sparse depth file for it in " + options.sparse_depth +
               " (looked for its name with " +
               std::to_string(predict::sparse_depth_extensions().size()) +
               " extensions): predicted without");
        }
      }
      item.sparse_depth = predict::resize_sparse_depth(item.sparse_depth, original.size(1),
                                                       original.size(0), size.width, size.height);

      const Prediction prediction = model.predict(image, item);
      predict::OutputOptions image_outputs = outputs;
      if (view != nullptr) image_outputs.camera_from_world = view->camera_from_world;
      const fs::path folder = fs::path(options.out_dir) / entry.output;
      const double writing_ms =
          predict::write_prediction_outputs(folder.string(), image, prediction, image_outputs);
      if (view != nullptr) fused.add(prediction, image, view->camera_from_world);

      std::string summary = prefix + entry.path.string() + " -> " + folder.string() + " (" +
                            std::to_string(prediction.mask.sum().item<int64_t>()) + " points";
      if (size.width != original.size(1))
        summary += " at " + std::to_string(size.width) + "x" + std::to_string(size.height);
      summary += ", metric scale " + fixed(prediction.metric_scale, 4);
      if (prediction.sparse_samples > 0)
        summary += ", aligned x" + fixed(prediction.alignment_factor, 4) + " to " +
                   std::to_string(prediction.sparse_samples) + " sparse samples";
      summary += ", decode " + std::to_string(static_cast<int>(decode_ms)) + " ms, network " +
                 std::to_string(static_cast<int>(prediction.timing.network_ms)) + " ms, writing " +
                 std::to_string(static_cast<int>(writing_ms)) + " ms)";
      progress.line(summary);
      for (const std::string& note : prediction.notes) progress.line("  note: " + note);
      if (!prediction.fit_error.empty())
        progress.line("  note: no camera fitted: " + prediction.fit_error);
      for (const std::string& warning : prediction.warnings) warn(warning);
    } catch (const std::exception& e) {
      ++failed;
      progress.line("omnipoint: error: " + prefix + "skipped " + entry.path.string() + ": " +
                    e.what());
    }
    progress.done();
  }
  if (!fused.points.empty()) {
    const fs::path path = fs::path(options.out_dir) / "fused.ply";
    const at::Tensor points = at::cat(fused.points), colors = at::cat(fused.colors);
    io::write_ply(path.string(), points, colors);
    progress.line(path.string() + ": " + std::to_string(points.size(0)) + " points of " +
                  std::to_string(fused.points.size()) +
                  " images in the reconstruction's world frame");
  }
  const int64_t total = static_cast<int64_t>(list.images.size());
  progress.line(std::to_string(total) + " image(s): " + std::to_string(total - failed) +
                " written, " + std::to_string(failed) + " failed, " + std::to_string(warnings) +
                " warning(s)");
  if (failed > 0)
    throw std::runtime_error(std::to_string(failed) + " of " + std::to_string(total) +
                             " images failed (see above)");
  if (options.view) {
    ViewOptions view;
    view.dir = options.out_dir;
    serve_predictions(view);
  }
}

}  // namespace

void add_predict_command(CLI::App& app) {
  auto options = std::make_shared<PredictCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "predict",
      "Predict a 3D point cloud from each image (files, or folders searched recursively; every "
      "format OpenCV decodes); writes OUT/<image path>/ with points.ply/.glb, .npy maps, PNG "
      "maps, a preview and camera.json (--outputs chooses)");
  command->add_option("images", options->inputs, "Image files or folders of images")->required();
  command->add_option(
      "--camera", options->camera,
      "Camera of the images: a COLMAP-style spec \"MODEL W H PARAMS...\" (a leading camera id is "
      "allowed), a JSON object, a cameras.txt (FILE#ID picks one), a camera.json written by "
      "predict, or a UniK3D camera JSON (default: the model predicts it)");
  command
      ->add_option("--fov", options->fov_deg,
                   "Horizontal field of view in degrees of a pinhole camera centred in each "
                   "image (instead of --camera)")
      ->check(CLI::Range(1.0, 179.0));
  command->add_option(
      "--colmap", options->colmap,
      "A COLMAP sparse model folder (cameras, images, points3D as .bin or .txt): each image gets "
      "its camera and, from the points it observes, sparse depth; outputs gain points_world.ply "
      "and OUT/fused.ply in the reconstruction's frame and units");
  command->add_option(
      "--sparse-depth", options->sparse_depth,
      "Sparse depth: a depth map (16-bit PNG, see --depth-scale; .npy or .exr in metres; 0 = "
      "missing) or a point cloud (.ply, .pcd, .bin); a folder holds one file per image name");
  command->add_flag("--sparse-depth-radial", options->sparse_depth_radial,
                    "The sparse depth map holds radial distance along each pixel's ray, not planar "
                    "depth z (panoramas, range images)");
  command
      ->add_option("--depth-scale", options->depth_scale,
                   "Depth PNG values per metre (default 1000: millimetres; 256 for KITTI)")
      ->check(CLI::PositiveNumber);
  command->add_option(
      "--lidar-to-camera", options->lidar_to_camera,
      "Camera-from-LiDAR transform of point clouds: 4x4 or 3x4 numbers in a text file, a KITTI "
      "calib_velo_to_cam.txt (R, T) or odometry calib.txt (Tr), or a .npy");
  command
      ->add_option("--lidar-format", options->lidar_format,
                   "Record layout of .bin scans: kitti (x y z intensity), nuscenes (x y z "
                   "intensity ring) or the number of float32 values per point")
      ->capture_default_str();
  command->add_option(
      "--model", options->model_path,
      "Model checkpoint (.safetensors, OmniPoint or MoGe-2; default: $OMNIPOINT_MODEL, else the "
      "bundled models/omnipoint_default.safetensors)");
  command->add_option("--out", options->out_dir, "Output folder (default: predictions)");
  command
      ->add_option("--max-size", options->max_size,
                   "Longest image side for the network and the outputs (the camera is rescaled; "
                   "default: the image's own size)")
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--outputs", options->outputs,
                   "Files to write, comma-separated: ply, glb, npy (points, distance, depth, rays, "
                   "normals), depth (depth.png, distance.png), mask, vis, preview, png (all PNGs), "
                   "mesh (mesh.glb), default (all but the mesh), all, or file names; camera.json "
                   "is always written")
      ->capture_default_str();
  command
      ->add_option("--edge-threshold", options->edge_rtol,
                   "Flying-pixel filter (MoGe's): drop pixels whose 3x3 neighbourhood's distances "
                   "span more than this fraction of their own (0: off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command
      ->add_option("--num-tokens", options->num_tokens, "ViT token budget (default: the model's)")
      ->check(CLI::PositiveNumber);
  command->add_option(
      "--fit-model", options->fit_model,
      "Camera model fitted to the predicted rays (COLMAP name; auto: a given camera as it is, else "
      "the simplest candidate of the smallest angular residual, camera/fit.h; none: no fit)");
  command->add_option("--device", options->device, "cpu, cuda or cuda:N (default cpu)");
  command->add_option("--precision", options->precision, kPrecisionHelp)->capture_default_str();
  command->add_flag("--view", options->view,
                    "When every image is written, show OUT in the browser as `omnipoint view OUT` "
                    "does (Ctrl-C stops)");
  command->add_flag("--cached-writes", options->cached_writes,
                    "Write files over 4 MiB through the page cache, not with direct I/O: better "
                    "for a single large prediction on a slow disk (SD card, eMMC, network "
                    "file system)");
  add_threads_option(command, &options->threads);
  command->callback([options] {
    use_threads(options->threads);
    io::set_large_file_writes(options->cached_writes ? io::LargeFileWrites::page_cache
                                                     : io::LargeFileWrites::direct);
    run_predict(*options);
  });
}

}  // namespace omnipoint::cli
