#pragma once
// KITTI raw and KITTI-360 calibration folders written from known rigs: every camera's
// intrinsics and its pose in the body frame (the truth), the files derived from them as the
// devkits define them (driving_files.h's number format). For `rig import` and `data convert`.
#include <ATen/ATen.h>

#include <filesystem>
#include <string>
#include <vector>

#include "driving_files.h"
#include "omnipoint/camera/camera.h"

namespace omnipoint::test {

// A rectified camera's intrinsics as KITTI prints them (P_rect_0X's K, S_rect_0X).
struct KittiIntrinsics {
  int64_t width, height;
  double fx, fy, u0, v0;
  // Ours: the devkits' (u0, v0) are integer-centred, cx = u0 + 0.5.
  camera::Camera camera() const {
    return camera::Camera("PINHOLE", width, height, {fx, fy, u0 + 0.5, v0 + 0.5});
  }
  at::Tensor k() const {
    return at::tensor({fx, 0.0, u0, 0.0, fy, v0, 0.0, 0.0, 1.0}, at::kDouble).view({3, 3});
  }
};

// A KITTI raw date folder's calibration. Truth: each rectified camera X's pose in the Velodyne
// frame, velo_from_camera[X]; the files: R_rect_00, P_rect_0X = K_X [I | t_X] and
// (R|T) = cam0_from_velo, with camera X = [I | t_X] · R_rect_00 · (R|T) (devkit readme.txt).
struct KittiRawCalibration {
  std::vector<KittiIntrinsics> intrinsics = {{48, 36, 40, 41, 23.3, 17.1},
                                             {48, 36, 42, 42.5, 24.25, 16.5},
                                             {50, 38, 39, 39.5, 25.125, 18.75},
                                             {50, 38, 38.5, 40, 24.5, 19.25}};
  at::Tensor rect = rotation(0.6, 0.8, 0.0, 0.012);  // R_rect_00
  at::Tensor cam0_from_velo = rigid(
      at::matmul(
          rotation(0.0, 0.0, 1.0, 0.02),
          at::tensor({0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0}, at::kDouble).view({3, 3})),
      at::tensor({-0.004, -0.076, -0.272}, at::kDouble));
  at::Tensor offset(int camera) const {  // t_X: image_02 left of image_00, image_03 right
    const double tx[] = {0.0, -0.54, 0.06, -0.48};
    return at::tensor({tx[camera], 0.002 * camera, 0.003}, at::kDouble);
  }
  // Camera X's rectified frame from the Velodyne's, and its pose (the inverse).
  at::Tensor camera_from_velo(int camera) const {
    return at::matmul(rigid(rect, offset(camera)), cam0_from_velo);
  }
  at::Tensor velo_from_camera(int camera) const { return at::inverse(camera_from_velo(camera)); }

  // calib_cam_to_cam.txt without the key `omit` (e.g. "P_rect_02"), and calib_velo_to_cam.txt.
  std::string cam_to_cam_text(const std::string& omit = "") const {
    std::string text = "calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\n";
    for (int camera = 0; camera < 4; ++camera) {
      const std::string id = "0" + std::to_string(camera);
      const KittiIntrinsics& in = intrinsics[static_cast<size_t>(camera)];
      const at::Tensor p = at::cat({in.k(), at::matmul(in.k(), offset(camera)).view({3, 1})}, 1);
      const std::vector<std::pair<std::string, std::string>> lines = {
          {"S_" + id, "1.392000e+03 5.120000e+02"},  // the unrectified sensor, unused
          {"K_" + id, kitti_numbers(in.k() * 1.1)},
          {"D_" + id, "-3.691481e-01 1.968681e-01 1.353473e-03 5.677587e-04 -6.770705e-02"},
          {"R_" + id, kitti_numbers(at::eye(3, at::kDouble))},
          {"T_" + id, kitti_numbers(offset(camera))},
          {"S_rect_" + id,
           kitti_numbers(at::tensor({double(in.width), double(in.height)}, at::kDouble))},
          {"R_rect_" + id, kitti_numbers(camera == 0 ? rect : at::eye(3, at::kDouble))},
          {"P_rect_" + id, kitti_numbers(p)}};
      for (const auto& [key, value] : lines)
        if (key != omit) text += key + ": " + value + "\n";
    }
    return text;
  }
  std::string velo_to_cam_text() const {
    return "calib_time: 15-Mar-2012 11:37:16\nR: " +
           kitti_numbers(cam0_from_velo.narrow(0, 0, 3).narrow(1, 0, 3)) +
           "\nT: " + kitti_numbers(cam0_from_velo.narrow(0, 0, 3).select(1, 3)) +
           "\ndelta_f: 0.000000e+00 0.000000e+00\ndelta_c: 0.000000e+00 0.000000e+00\n";
  }
  void write(const std::filesystem::path& date) const {
    write_text(date / "calib_cam_to_cam.txt", cam_to_cam_text());
    write_text(date / "calib_velo_to_cam.txt", velo_to_cam_text());
  }
};

// A KITTI-360 calibration folder. Truth: each camera's pose in the GPS/IMU pose frame (the
// perspective cameras' rectified frames), body_from_camera[X], and the Velodyne's; the files:
// calib_cam_to_pose.txt (unrectified cameras: body_from_camera · R_rect_0X), perspective.txt,
// image_02/03.yaml (MEI) and calib_cam_to_velo.txt (image_00 unrectified -> Velodyne).
struct Kitti360Calibration {
  std::vector<at::Tensor> body_from_camera = {
      rigid(rotation(0.0, 0.6, 0.8, 1.3), at::tensor({1.57, 0.004, -0.65}, at::kDouble)),
      rigid(rotation(0.0, 0.8, 0.6, 1.2), at::tensor({1.56, -0.59, -0.66}, at::kDouble)),
      rigid(rotation(0.8, 0.0, 0.6, -1.1), at::tensor({0.73, -0.15, -0.86}, at::kDouble)),
      rigid(rotation(0.6, 0.0, -0.8, 1.4), at::tensor({0.69, 1.21, -0.85}, at::kDouble))};
  at::Tensor body_from_velo =
      rigid(rotation(0.0, 0.0, 1.0, 0.03), at::tensor({0.81, -0.32, 0.8}, at::kDouble));
  std::vector<at::Tensor> rect = {rotation(1.0, 0.0, 0.0, 0.01), rotation(0.0, 1.0, 0.0, 0.015)};
  std::vector<KittiIntrinsics> perspective = {{40, 30, 35, 35, 19.2, 14.6},
                                              {40, 30, 36, 36.5, 20.25, 13.5}};
  // gamma1, gamma2, u0, v0, xi, k1, k2, p1, p2 of image_02 and image_03 (64 x 64).
  std::vector<std::vector<double>> mei = {{30, 31, 31.3, 32.2, 1.1, 0.02, 0.01, 0.02, -0.015},
                                          {29, 29.5, 32.5, 31.75, 0.9, -0.01, 0.005, 0, 0}};
  // Ours of image_02/03: (u0, v0) + 0.5, p1 = p2 = 0 (the devkit's projection ignores them).
  camera::Camera fisheye(int camera) const {
    const std::vector<double>& m = mei[static_cast<size_t>(camera - 2)];
    return camera::Camera("MEI", 64, 64,
                          {m[0], m[1], m[2] + 0.5, m[3] + 0.5, m[4], m[5], m[6], 0, 0});
  }
  camera::Camera camera(int camera) const {
    return camera < 2 ? perspective[static_cast<size_t>(camera)].camera() : fisheye(camera);
  }
  // The unrectified camera's pose (what calib_cam_to_pose.txt holds).
  at::Tensor pose_from_camera(int camera) const {
    const at::Tensor pose = body_from_camera[static_cast<size_t>(camera)];
    return camera < 2 ? at::matmul(pose, rigid(rect[static_cast<size_t>(camera)],
                                               at::zeros({3}, at::kDouble)))
                      : pose;
  }

  std::string yaml(int camera) const {
    const std::vector<double>& m = mei[static_cast<size_t>(camera - 2)];
    const auto line = [](const char* key, double value) {
      return std::string("   ") + key + ": " + kitti_numbers(at::tensor({value}, at::kDouble)) +
             "\n";
    };
    return "%YAML:1.0\nmodel_type: MEI\ncamera_name: image_0" + std::to_string(camera) +
           "\nimage_width: 64\nimage_height: 64\nmirror_parameters:\n" + line("xi", m[4]) +
           "distortion_parameters:\n" + line("k1", m[5]) + line("k2", m[6]) + line("p1", m[7]) +
           line("p2", m[8]) + "projection_parameters:\n" + line("gamma1", m[0]) +
           line("gamma2", m[1]) + line("u0", m[2]) + line("v0", m[3]);
  }
  std::string cam_to_pose_text() const {
    std::string text;
    for (int camera = 0; camera < 4; ++camera)
      text += "image_0" + std::to_string(camera) + ": " +
              kitti_numbers(pose_from_camera(camera).narrow(0, 0, 3)) + "\n";
    return text;
  }
  std::string perspective_text() const {
    std::string text = "calib_time: 09-Jan-2012 13:57:47\n";
    for (int camera = 0; camera < 2; ++camera) {
      const std::string id = "0" + std::to_string(camera);
      const KittiIntrinsics& in = perspective[static_cast<size_t>(camera)];
      text += "S_rect_" + id + ": " +
              kitti_numbers(at::tensor({double(in.width), double(in.height)}, at::kDouble)) +
              "\nR_rect_" + id + ": " + kitti_numbers(rect[static_cast<size_t>(camera)]) +
              "\nP_rect_" + id + ": " +
              kitti_numbers(at::cat({in.k(), at::zeros({3, 1}, at::kDouble)}, 1)) + "\n";
    }
    return text;
  }
  void write(const std::filesystem::path& root) const {
    const std::filesystem::path calibration = root / "calibration";
    write_text(calibration / "calib_cam_to_pose.txt", cam_to_pose_text());
    // image_00 (unrectified) -> Velodyne = velo_from_body · body_from_cam00.
    write_text(calibration / "calib_cam_to_velo.txt",
               kitti_numbers(
                   at::matmul(at::inverse(body_from_velo), pose_from_camera(0)).narrow(0, 0, 3)) +
                   "\n");
    write_text(calibration / "perspective.txt", perspective_text());
    for (int camera : {2, 3})
      write_text(calibration / ("image_0" + std::to_string(camera) + ".yaml"), yaml(camera));
  }
};

}  // namespace omnipoint::test
