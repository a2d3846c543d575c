// omnipoint reproject: Perspective-to-Any for one sample folder (docs/AUGMENTATION.md).
//   --camera SPEC            render the sample into that camera (turned by --yaw/--pitch/--roll)
//   --perspective FOV        cut a centred pinhole view (FoV in degrees, --width x --height)
//                            looking along --yaw/--pitch out of a panorama or fisheye sample
// Both write a sample folder in the dataset format (image, distance, mask, meta) plus
// rays.npy; meta.json records the source folder and the rotation.
#include <ATen/ATen.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "omnipoint/augment/a2p.h"
#include "omnipoint/augment/p2a.h"
#include "omnipoint/augment/warp.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::cli {

void add_reproject_command(CLI::App& app) {
  struct Args {
    std::string input, out, camera;
    double perspective = 0, yaw = 0, pitch = 0, roll = 0, tolerance = 0.05;
    int64_t width = 640, height = 480, supersample = 0;
    bool no_fill = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("reproject",
                                 "Render a labelled sample into another camera "
                                 "(Perspective-to-Any), or cut a pinhole view out of a "
                                 "panorama/fisheye sample; writes a sample folder");
  cmd->add_option("--input", args->input, "sample folder (image, distance|depth, mask, meta.json)")
      ->required();
  cmd->add_option("--out", args->out, "output sample folder")->required();
  auto* camera_option =
      cmd->add_option("--camera", args->camera, "target camera spec (COLMAP line, JSON, or file)");
  auto* perspective_option = cmd->add_option(
      "--perspective", args->perspective, "horizontal FoV in degrees of a pinhole view to extract");
  camera_option->excludes(perspective_option);
  cmd->add_option("--yaw", args->yaw, "degrees, the view axis turns from +z towards +x")
      ->capture_default_str();
  cmd->add_option("--pitch", args->pitch, "degrees, > 0 looks up")->capture_default_str();
  cmd->add_option("--roll", args->roll, "degrees about the view axis")->capture_default_str();
  cmd->add_option("--width", args->width, "width of the --perspective view")->capture_default_str();
  cmd->add_option("--height", args->height, "height of the --perspective view")
      ->capture_default_str();
  cmd->add_option("--supersample", args->supersample,
                  "splats per source pixel along each axis (0: automatic)")
      ->capture_default_str();
  cmd->add_option("--tolerance", args->tolerance, "relative depth agreement for valid pixels")
      ->capture_default_str();
  cmd->add_flag("--no-fill", args->no_fill,
                "leave z-buffer gaps black (they are never labelled either way)");
  cmd->callback([args] {
    if (args->camera.empty() && args->perspective == 0) {
      throw std::invalid_argument("reproject: give --camera SPEC or --perspective FOV");
    }
    const data::Sample source = data::read_sample(args->input);
    const bool perspective = args->camera.empty();
    if (perspective && !(args->perspective > 0 && args->perspective < 180)) {
      throw std::invalid_argument("--perspective " + std::to_string(args->perspective) +
                                  ": expected a FoV in (0, 180) degrees");
    }
    if (perspective && (args->width < 1 || args->height < 1)) {
      throw std::invalid_argument("--width/--height: expected positive sizes");
    }
    const camera::Camera target =
        perspective ? camera::centred_pinhole(args->perspective, args->width, args->height)
                    : io::read_camera(args->camera);
    const at::Tensor rotation = augment::rotation_from_angles(args->yaw, args->pitch, args->roll);
    augment::P2AOptions options;
    options.supersample = args->supersample;
    options.tolerance = args->tolerance;
    options.fill_holes = !args->no_fill;
    const augment::P2AResult result = augment::perspective_to_any(
        source.camera, source.image, source.distance, source.mask, {target, rotation, {}}, options);
    data::Sample out{target, result.image, result.distance * result.mask, result.mask,
                     source.metric};
    if (perspective) {
      // A pinhole cut keeps the sky and everything else the lens saw: bilinear image samples.
      const augment::PerspectiveView view{target, rotation};
      out.image =
          augment::extract_view(source.camera, source.image, view, source.camera.ray_map().valid)
              .image;
    }
    nlohmann::json meta = {{"reproject",
                            {{"source", args->input},
                             {"mode", perspective ? "perspective" : "camera"},
                             {"yaw_deg", args->yaw},
                             {"pitch_deg", args->pitch},
                             {"roll_deg", args->roll}}}};
    data::write_sample(args->out, out, meta.dump());
    io::write_npy(args->out + "/rays.npy", result.rays.to(at::kFloat).contiguous());
    std::cout << args->out << "\n";
  });
}

}  // namespace omnipoint::cli
