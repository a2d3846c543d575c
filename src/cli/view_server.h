#pragma once
// `omnipoint view`: a read-only web server for the prediction folders under one folder (the
// `predict` layout, predict/outputs.h) and the rig frames of `predict --rig` (rig.json, fused.ply
// and a prediction folder per camera, predict/rig_predict_job.h), and the page that shows them
// (src/cli/view/: one HTML, one JS module, one CSS; three.js from the npm package the build
// installs).
//
// Routes (GET and HEAD only; other methods get 405):
//   /, /view.js, /view.css    the page
//   /three/...                three.js's files (the import map's `three` and `three/addons/`)
//   /api/predictions          {"root", "max_points", "predictions": [{"name", "kind", "points"}]},
//                             kind "prediction" or "rig"
//   /api/prediction?name=NAME a prediction folder: its files, camera.json, the camera's class
//                             and, unless it is too wide for a frustum, the rays through the
//                             image border; a rig frame: rig.json, the body frame's up direction
//                             and its cameras (rig.json's entries with their folder, class and
//                             frustum rays)
//   /cloud?name=NAME          a prediction's points.glb, or at most max_points of its points.ply
//                             as a GLB (a rig frame's: fused.glb, fused.ply); headers
//                             X-Omnipoint-Points-Total and X-Omnipoint-Points-Shown
//   /files/NAME/FILE          a file of the folder
//   /colourised/NAME/FILE     a 16-bit map of it (depth.png) as a colour picture
// Only files under the served folder are read: a path with a `..` component, or one whose
// canonical form (symlinks resolved) leaves the folder, gets 403; a missing one 404.
#include <cstdint>
#include <filesystem>
#include <string>

namespace omnipoint::cli {

struct ViewOptions {
  std::filesystem::path dir;  // the folder of predictions
  std::string host = "127.0.0.1";
  int port = 8080;  // 0: any free port
  int64_t max_points = 1'500'000;
  bool open_browser = false;
};

// Serves the prediction folders and rig frames under options.dir (those holding a camera.json
// or a rig.json, the folder itself included as ".") until interrupted. Prints "omnipoint view:
// serving [M rig frame(s) and ]N prediction(s) of DIR at URL" on stdout once listening (port 0:
// the port the system chose). A DIR that is missing or holds neither, a rig frame whose rig.json
// does not parse or lacks a camera's pose, scale or scale source, or that has no fused cloud,
// and a port that cannot be bound -> std::invalid_argument / std::runtime_error.
void serve_predictions(const ViewOptions& options);

// Whether this build has the viewer (OMNIPOINT_WITH_VIEWER); without it serve_predictions
// throws, so that `predict --view` can refuse before predicting anything.
bool viewer_available();

}  // namespace omnipoint::cli
