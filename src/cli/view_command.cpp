// omnipoint view DIR: the prediction folders and rig frames under DIR in the browser
// (cli/view_server.h).
#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/view_server.h"

namespace omnipoint::cli {

void add_view_command(CLI::App& app) {
  auto options = std::make_shared<ViewOptions>();
  CLI::App* command = app.add_subcommand(
      "view",
      "Show the predictions under a folder (the layout `predict` writes) in a web browser: the "
      "image, its depth, distance and mask pictures, camera.json's summary and the point cloud "
      "in 3D; a rig frame of `predict --rig` (its rig.json) as its fused cloud in the body frame "
      "with every camera placed by its pose; serves this machine only unless --host says "
      "otherwise");
  command
      ->add_option("dir", options->dir,
                   "A folder of prediction folders and rig frames, or one of them")
      ->required();
  command->add_option("--port", options->port, "TCP port (0: any free one; the URL is printed)")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  command
      ->add_option("--host", options->host,
                   "Address to listen on; anything but 127.0.0.1, localhost or ::1 lets other "
                   "machines read every file under DIR")
      ->capture_default_str();
  command
      ->add_option("--max-points", options->max_points,
                   "Most points a cloud is shown with (larger ones are subsampled evenly)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  command->add_flag("--open", options->open_browser,
                    "Open the page in this machine's browser (xdg-open), else print where to");
  command->callback([options] { serve_predictions(*options); });
}

}  // namespace omnipoint::cli
