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
      // Fisheye and unified models, most with fields of view over 180 degrees. Their folds
      // (where a lens stops being injective) lie outside the images: next to a fold, float32
      // pixels cannot pin rays down to 1e-5 (test_fisheye_models.cpp covers folds in view).
      "OPENCV_FISHEYE 640 480 185.3 184.8 319.3 241.6 0.025 -0.011 0.0016 -0.0001",
      "OPENCV_FISHEYE 640 480 287.4 286.9 322.1 238.9 -0.012 0.0047 -0.0021 0.0003",
      "SIMPLE_RADIAL_FISHEYE 640 480 205.3 320.4 239.2 -0.031",
      "RADIAL_FISHEYE 640 480 198.6 318.7 240.8 -0.024 0.0016",
      // NOLINTBEGIN(bugprone-suspicious-missing-comma): long specs continue on the next line.
      "THIN_PRISM_FISHEYE 640 480 190.2 189.7 321.5 238.4 0.021 -0.0035 0.0004 -0.0003 0.0006 "
      "-0.0001 0.0005 -0.0002",
      "RAD_TAN_THIN_PRISM_FISHEYE 640 480 182.5 182.9 319.8 241.2 0.045 -0.012 0.0015 -0.0001 "
      "0.00001 -0.0000005 0.0003 -0.0002 0.0004 -0.00005 -0.0003 0.00004",
      // NOLINTEND(bugprone-suspicious-missing-comma)
      "MEI 640 480 420.5 419.3 321.4 238.7 1.35 -0.12 0.05 0.0006 -0.0004",
      "UCM 640 480 161.3 160.8 318.6 242.3 0.55",
      "EUCM 640 480 180.2 179.9 321.7 239.4 0.58 1.08",
      "EUCM 640 480 331.7 332.2 318.2 240.9 0.82 0.93",
      "DOUBLE_SPHERE 640 480 140.3 140.1 320.6 239.8 -0.2 0.55",
  };
  return specs;
}

}  // namespace omnipoint::camera::testing
