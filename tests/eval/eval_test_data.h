#pragma once
// Tiny synthetic evaluation datasets for the runner tests: a few samples per camera split,
// rendered by the synthetic engine (no shadows or ambient occlusion, so it is quick).
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/synthesize.h"
#include "support/fast_synth.h"

namespace omnipoint::eval::testing {

// One camera per split: pinhole (S.FoV), a 190° equidistant fisheye (L.FoV), a panorama (360°).
inline const std::vector<std::string>& tiny_cameras() {
  static const std::vector<std::string> cameras{"PINHOLE 32 24 24 24 16 12",
                                                "OPENCV_FISHEYE 32 32 9.6 9.6 16 16 0 0 0 0",
                                                "EQUIRECTANGULAR 32 16"};
  return cameras;
}

// A fresh folder holding `per_split` samples per camera of tiny_cameras() (indoor and outdoor
// alternating), in sub-folders named after the split.
inline std::filesystem::path make_tiny_dataset(const std::string& name, int per_split = 2) {
  namespace fs = std::filesystem;
  const fs::path root =
      fs::temp_directory_path() / ("omnipoint_eval_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const data::synth::SynthOptions options = test::fast_synth();
  const std::vector<std::string> splits{"sfov", "lfov", "pano"};
  for (size_t s = 0; s < splits.size(); ++s) {
    const auto camera = camera::parse_camera(tiny_cameras()[s]);
    for (int i = 0; i < per_split; ++i) {
      const auto kind = i % 2 ? data::synth::SceneKind::kOutdoor : data::synth::SceneKind::kIndoor;
      data::synth::write_synth_sample(
          (root / splits[s] / std::to_string(i)).string(),
          data::synth::synthesize(kind, 100 + 10 * s + i, camera, options));
    }
  }
  return root;
}

}  // namespace omnipoint::eval::testing
