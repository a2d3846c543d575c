// omnipoint camera rays|info|fit: a camera's per-pixel rays, a summary of the camera, and the
// camera of a chosen model that best explains a ray map.
#include <ATen/ATen.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/camera_info.h"
#include "omnipoint/camera/fit.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::cli {
namespace {

// The camera given by --camera SPEC, or by the short form --fov DEG --width W --height H.
struct CameraOptions {
  std::string spec;
  double fov_deg = 0;
  int64_t width = 0;
  int64_t height = 0;

  void add_to(CLI::App& command) {
    auto* camera =
        command.add_option("--camera", spec,
                           "Camera: a COLMAP line 'MODEL W H PARAMS...', a JSON object, or a "
                           "file (cameras.txt, optionally path#ID; .json)");
    auto* fov = command.add_option("--fov", fov_deg,
                                   "Short form: a centred pinhole with this horizontal FoV "
                                   "(degrees); needs --width and --height");
    command.add_option("--width", width, "Image width for --fov")->needs(fov);
    command.add_option("--height", height, "Image height for --fov")->needs(fov);
    camera->excludes(fov);
  }

  camera::Camera camera() const {
    if (!spec.empty()) return io::read_camera(spec);
    if (fov_deg == 0)
      throw std::invalid_argument(
          "give the camera with --camera SPEC or --fov DEG --width W --height H");
    if (width <= 0 || height <= 0)
      throw std::invalid_argument("--fov needs --width and --height > 0");
    return camera::centred_pinhole(fov_deg, width, height);
  }
};

// Rays (H, W, 3) as an RGB picture: each component from [-1, 1] to [0, 1]; invalid black.
void write_ray_png(const std::string& path, const camera::Rays& map) {
  io::write_image_png(path, (map.rays + 1) * 0.5 * map.valid.unsqueeze(-1));
}

void add_rays_command(CLI::App& parent) {
  auto* command =
      parent.add_subcommand("rays",
                            "Write the camera's unit rays at pixel centres (H x W x 3 float32 "
                            ".npy, zero where invalid)");
  auto options = std::make_shared<CameraOptions>();
  auto out = std::make_shared<std::string>();
  auto png = std::make_shared<std::string>();
  options->add_to(*command);
  command->add_option("--out", *out, "Output .npy file")->required();
  command->add_option("--png", *png, "Also write the rays as an RGB picture (PNG)");
  command->callback([options, out, png] {
    const auto camera = options->camera();
    const auto map = camera.ray_map(at::kFloat);
    if (!png->empty()) write_ray_png(*png, map);
    io::write_npy(*out, map.rays);
  });
}

void add_info_command(CLI::App& parent) {
  auto* command =
      parent.add_subcommand("info",
                            "Print the camera as JSON: model, size, parameters, fields of view "
                            "(degrees) and the share of valid pixels");
  auto options = std::make_shared<CameraOptions>();
  options->add_to(*command);
  command->callback([options] {
    const auto camera = options->camera();
    const auto fov = camera::field_of_view(camera);
    const nlohmann::json info = {{"model", camera.model_name()},
                                 {"width", camera.width()},
                                 {"height", camera.height()},
                                 {"params", camera.params()},
                                 {"param_names", camera.model().param_names()},
                                 {"spec", camera.to_spec()},
                                 {"fov_deg",
                                  {{"horizontal", fov.horizontal_deg},
                                   {"vertical", fov.vertical_deg},
                                   {"diagonal", fov.diagonal_deg}}},
                                 {"valid_fraction", camera::valid_fraction(camera)}};
    std::cout << info.dump(2) << "\n";
  });
}

void add_fit_command(CLI::App& parent) {
  auto* command =
      parent.add_subcommand("fit",
                            "Fit a camera of a chosen model (or auto) to a ray map (H x W x 3 "
                            ".npy, zero rays are invalid) and print it as JSON with its COLMAP "
                            "spec and angular residual");
  auto rays_path = std::make_shared<std::string>();
  auto model = std::make_shared<std::string>();
  command
      ->add_option("--rays", *rays_path,
                   "Ray map .npy (H x W x 3), e.g. from `camera rays` or a prediction")
      ->required();
  command
      ->add_option("--model", *model,
                   "Camera model to fit, e.g. PINHOLE, OPENCV, OPENCV_FISHEYE, or auto (the "
                   "simplest that explains the rays, as predict --fit-model auto)")
      ->required();
  command->callback([rays_path, model] {
    const auto rays = io::read_npy(*rays_path);
    if (rays.dim() != 3 || rays.size(2) != 3 || !at::isFloatingType(rays.scalar_type())) {
      throw std::invalid_argument(*rays_path + ": expected a floating-point H x W x 3 ray map");
    }
    const auto valid = camera::length(rays.to(at::kDouble)) > 0.5;
    const int64_t width = rays.size(1), height = rays.size(0);
    const camera::CameraFit fitted =
        *model == "auto" ? camera::fit_camera_auto(width, height, rays, valid)
                         : camera::fit_camera_model(*model, width, height, rays, valid);
    auto info = nlohmann::json::parse(fitted.camera.to_json());
    info["spec"] = fitted.camera.to_spec();
    info["fit_residual_deg"] = {{"median", fitted.residual.median_deg},
                                {"mean", fitted.residual.mean_deg},
                                {"max", fitted.residual.max_deg}};
    std::cout << info.dump(2) << "\n";
  });
}

}  // namespace

void add_camera_command(CLI::App& app) {
  auto* camera = app.add_subcommand(
      "camera", "Camera models: per-pixel rays, camera summaries, fitting a camera to rays");
  camera->require_subcommand(1);
  add_rays_command(*camera);
  add_info_command(*camera);
  add_fit_command(*camera);
}

}  // namespace omnipoint::cli
