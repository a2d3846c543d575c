#pragma once
// One realistic camera per model: the typed tests (test_camera_models.cpp) run over all of
// them. Adding a model: append its sample here.
#include <string>
#include <vector>

namespace omnipoint::camera::testing {

inline const std::vector<std::string>& sample_camera_specs() {
  static const std::vector<std::string> specs = {
      "SIMPLE_PINHOLE 640 480 520 320 240",
      "PINHOLE 640 480 525.5 519.25 319.5 241.75",
  };
  return specs;
}

}  // namespace omnipoint::camera::testing
