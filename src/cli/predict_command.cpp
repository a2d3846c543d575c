// omnipoint predict: images (+ camera, + sparse depth) -> one output folder per image
// (predict/outputs.h). A bad image or sparse-depth file skips that image with one line on
// stderr; the command then ends with a non-zero status.
#include <ATen/ATen.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::cli {

namespace {

namespace fs = std::filesystem;

struct PredictCommandOptions {
  std::vector<std::string> inputs;
  std::string camera;
  std::string sparse_depth;
  std::string lidar_to_camera;
  bool sparse_depth_radial = false;
  std::string model_path;
  std::string out_dir = "predictions";
  int64_t num_tokens = 0;
  std::string fit_model = "auto";
  std::string device = "cpu";
};

std::string lower_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

bool is_image_file(const fs::path& path) {
  const std::string ext = lower_extension(path);
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

// Folders expand to their PNG/JPEG files (sorted); files are taken as given.
std::vector<fs::path> expand_inputs(const std::vector<std::string>& inputs) {
  std::vector<fs::path> images;
  for (const std::string& input : inputs) {
    if (fs::is_directory(input)) {
      std::vector<fs::path> found;
      for (const auto& entry : fs::directory_iterator(input))
        if (entry.is_regular_file() && is_image_file(entry.path())) found.push_back(entry.path());
      if (found.empty())
        throw std::invalid_argument("input folder " + input + ": no PNG or JPEG images in it");
      std::sort(found.begin(), found.end());
      images.insert(images.end(), found.begin(), found.end());
    } else {
      images.emplace_back(input);
    }
  }
  return images;
}

// The sparse depth of one image: the file itself, or in a folder the file with the image's
// stem (none: no sparse depth for that image).
std::optional<std::string> sparse_depth_for(const std::string& option, const fs::path& image) {
  if (option.empty()) return std::nullopt;
  if (!fs::is_directory(option)) return option;
  for (const char* ext : {".png", ".npy", ".exr", ".ply", ".bin"}) {
    const fs::path candidate = fs::path(option) / (image.stem().string() + ext);
    if (fs::exists(candidate)) return candidate.string();
  }
  return std::nullopt;
}

// --model, else $OMNIPOINT_MODEL, else the bundled model: installed beside the tool
// (<prefix>/bin/omnipoint -> <prefix>/share/omnipoint/), else in the source tree it was built from.
std::string model_path_or_bundled(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* environment = std::getenv("OMNIPOINT_MODEL");
      environment != nullptr && *environment != '\0')
    return environment;
  std::error_code error;
  const fs::path executable = fs::read_symlink("/proc/self/exe", error);
  const fs::path installed = executable.parent_path().parent_path() / OMNIPOINT_INSTALLED_MODEL;
  if (!error && fs::exists(installed)) return installed.string();
  if (fs::exists(OMNIPOINT_SOURCE_MODEL)) return OMNIPOINT_SOURCE_MODEL;
  throw std::invalid_argument(
      std::string("no model given and the bundled one is missing (looked for ") +
      installed.string() + " and " + OMNIPOINT_SOURCE_MODEL +
      "): pass a checkpoint with --model FILE");
}

void run_predict(const PredictCommandOptions& options) {
  if (!io::image_io_available())
    throw std::runtime_error("this build has no image file I/O (OpenCV)");
  const std::vector<fs::path> images = expand_inputs(options.inputs);
  if (images.size() > 1 && !options.sparse_depth.empty() && !fs::is_directory(options.sparse_depth))
    throw std::invalid_argument(
        "--sparse-depth " + options.sparse_depth +
        ": one file for several images; pass a folder with a file per image stem");
  predict::PredictOptions base;
  if (!options.camera.empty()) base.camera = io::read_camera(options.camera);
  base.num_tokens = options.num_tokens;
  base.fit_model = options.fit_model == "none" ? "" : options.fit_model;
  const Model model =
      Model::load(model_path_or_bundled(options.model_path), at::Device(options.device));

  std::map<std::string, int> stems;  // output folder names stay unique
  size_t failed = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    const fs::path& path = images[i];
    std::string name = path.stem().string();
    if (const int seen = stems[name]++; seen > 0) name += "_" + std::to_string(seen + 1);
    const fs::path folder = fs::path(options.out_dir) / name;
    const std::string progress =
        images.size() > 1 ? "[" + std::to_string(i + 1) + "/" + std::to_string(images.size()) + "] "
                          : "";
    try {
      const auto start = std::chrono::steady_clock::now();
      const at::Tensor image = io::read_image(path.string());
      const double decode_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      predict::PredictOptions item = base;
      if (const auto sparse = sparse_depth_for(options.sparse_depth, path)) {
        item.sparse_depth = predict::read_sparse_depth(*sparse, options.lidar_to_camera);
        if (options.sparse_depth_radial) {
          if (!item.sparse_depth.depth_map.defined())
            throw std::invalid_argument("sparse depth " + *sparse +
                                        ": --sparse-depth-radial applies to depth maps only");
          item.sparse_depth.depth_is_planar = false;
        }
      }
      const Prediction prediction = model.predict(image, item);
      const double writing_ms =
          predict::write_prediction_outputs(folder.string(), image, prediction);
      std::cerr << progress << path.string() << " -> " << folder.string() << " ("
                << static_cast<int>(prediction.mask.sum().item<int64_t>())
                << " points, metric scale " << prediction.metric_scale << ", decode "
                << static_cast<int>(decode_ms) << " ms, network "
                << static_cast<int>(prediction.timing.network_ms) << " ms, writing "
                << static_cast<int>(writing_ms) << " ms)\n";
      for (const std::string& note : prediction.notes) std::cerr << "  note: " << note << "\n";
      if (!prediction.fit_error.empty())
        std::cerr << "  note: no camera fitted: " << prediction.fit_error << "\n";
    } catch (const std::exception& e) {
      ++failed;
      std::cerr << "omnipoint: error: " << progress << "skipped " << path.string() << ": "
                << e.what() << "\n";
    }
  }
  if (failed > 0)
    throw std::runtime_error(std::to_string(failed) + " of " + std::to_string(images.size()) +
                             " images failed (see above)");
}

}  // namespace

void add_predict_command(CLI::App& app) {
  auto options = std::make_shared<PredictCommandOptions>();
  CLI::App* command =
      app.add_subcommand("predict",
                         "Predict a metric 3D point cloud from each image "
                         "(PNG/JPEG, 8/16-bit, grey/RGB/RGBA; files or folders); "
                         "writes points.ply, points.glb, points/distance/depth/rays "
                         ".npy, "
                         "mask/depth/depth_vis/preview .png and camera.json "
                         "into OUT/<image name>/");
  command->add_option("images", options->inputs, "Image files or folders of images")->required();
  command->add_option(
      "--camera", options->camera,
      "Camera of the images: a COLMAP-style spec \"MODEL W H PARAMS...\", a JSON object, or a "
      "cameras.txt / camera.json file (default: the model predicts it)");
  command->add_option(
      "--sparse-depth", options->sparse_depth,
      "Metric sparse depth: depth image (16-bit PNG in mm, .npy or .exr in metres, 0 = missing) or "
      "point cloud (.ply, KITTI .bin); a folder holds one file per image stem");
  command->add_flag("--sparse-depth-radial", options->sparse_depth_radial,
                    "The sparse depth map holds radial distance along each pixel's ray, not planar "
                    "depth z (panoramas, range images)");
  command->add_option(
      "--lidar-to-camera", options->lidar_to_camera,
      "Camera-from-LiDAR transform of a point cloud: 4x4 (or 3x4) numbers in a text file, or .npy");
  command->add_option(
      "--model", options->model_path,
      "Model checkpoint (.safetensors, OmniPoint or MoGe-2; default: $OMNIPOINT_MODEL, else the "
      "bundled models/omnipoint_default.safetensors)");
  command->add_option("--out", options->out_dir, "Output folder (default: predictions)");
  command
      ->add_option("--num-tokens", options->num_tokens, "ViT token budget (default: the model's)")
      ->check(CLI::PositiveNumber);
  command->add_option(
      "--fit-model", options->fit_model,
      "Camera model fitted to the predicted rays (COLMAP name; auto: the given camera's model or "
      "chosen from the field of view; none: no fit)");
  command->add_option("--device", options->device, "cpu or cuda (default cpu)");
  command->callback([options] { run_predict(*options); });
}

}  // namespace omnipoint::cli
