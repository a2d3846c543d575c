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
      "SIMPLE_RADIAL 640 480 500 320 240 -0.1",
      "RADIAL 400 300 310 200 150 -0.12 0.03",
      "OPENCV 640 360 450 452.5 320.5 179.5 -0.28 0.09 0.0008 -0.0005",
      // Corners beyond the monotonic range of the radial polynomial: invalid pixels.
      "OPENCV 640 360 250 250 320 180 -0.35 0.02 0 0",
      "FULL_OPENCV 512 384 350 351 256 192 -0.25 0.07 0.0005 -0.0003 0.01 0.02 0.005 0.001",
      "FOV 640 480 290 291 320 240 0.92",
      "EQUIRECTANGULAR 512 256",
      "EQUIRECTANGULAR 400 300 -1.2 1.0 -0.7 0.8",
  };
  return specs;
}

}  // namespace omnipoint::camera::testing
