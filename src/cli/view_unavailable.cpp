// `omnipoint view` and `predict --view` in a build without the viewer (OMNIPOINT_WITH_VIEWER=OFF,
// e.g. on a machine without npm): both exist, and say so in one line instead of being unknown.
#include <CLI/CLI.hpp>

#include <stdexcept>

#include "cli/commands.h"
#include "cli/view_server.h"

namespace omnipoint::cli {
namespace {

[[noreturn]] void viewer_unavailable() {
  throw std::runtime_error(
      "this omnipoint was built without the viewer (OMNIPOINT_WITH_VIEWER=OFF); rebuild with it "
      "ON, which needs libcpp-httplib-dev and npm (scripts/install_deps.sh)");
}

}  // namespace

void add_view_command(CLI::App& app) {
  CLI::App* command =
      app.add_subcommand("view", "Not in this build (configured with OMNIPOINT_WITH_VIEWER=OFF)");
  command->allow_extras();
  command->callback([] { viewer_unavailable(); });
}

bool viewer_available() {
  return false;
}

void serve_predictions(const ViewOptions&) {
  viewer_unavailable();
}

}  // namespace omnipoint::cli
