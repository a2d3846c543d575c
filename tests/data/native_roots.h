#pragma once
// Small dataset roots in their formats' native layouts, as the tests write them: a KITTI raw
// drive and a Stanford2D3D panorama folder (for `data convert` and the every-format test).
#include <ATen/ATen.h>

#include <filesystem>
#include <string>

#include "driving_files.h"
#include "kitti_calibration_files.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/io/image.h"
#include "support/scratch_dir.h"

namespace omnipoint::test {

inline const char* const kKittiRawDate = "2011_09_26";
inline const char* const kKittiRawDrive = "2011_09_26_drive_0001_sync";

inline std::filesystem::path kitti_raw_sweep_path(const std::filesystem::path& root, int frame) {
  return root / kKittiRawDate / kKittiRawDrive / "velodyne_points" / "data" /
         (frame_stem(frame) + ".bin");
}

// A KITTI raw root: `frames` frames of image_02 and image_03, each sweep holding points in
// front of camera 2 at distances that tell the frames apart.
inline std::filesystem::path write_kitti_raw(const std::string& name, int frames) {
  const std::filesystem::path root = fresh_process_dir(name);
  const KittiRawCalibration calibration;
  calibration.write(root / kKittiRawDate);
  const camera::Camera camera = calibration.intrinsics[2].camera();
  for (int frame = 0; frame < frames; ++frame) {
    const at::Tensor pixels =
        at::tensor({3.25, 4.75, 20.5, 10.25, 40.75, 30.5, 11.5, 25.5}, at::kDouble).view({4, 2});
    const at::Tensor points =
        camera.unproject(pixels).rays *
        at::tensor({4.5, 7.25, 12.0, 5.0}, at::kDouble).add(frame).view({4, 1});
    write_sweep(kitti_raw_sweep_path(root, frame),
                transformed(calibration.velo_from_camera(2), points));
    for (int c : {2, 3}) {
      const std::filesystem::path image = root / kKittiRawDate / kKittiRawDrive /
                                          ("image_0" + std::to_string(c)) / "data" /
                                          (frame_stem(frame) + ".png");
      std::filesystem::create_directories(image.parent_path());
      const at::Tensor pixels_rgb =
          (at::arange(38 * 50 * 3, at::kLong).view({38, 50, 3}) * 7 + frame * 11 + c)
              .remainder(256)
              .to(at::kByte);
      io::write_image_png(image.string(), pixels_rgb);
    }
  }
  return root;
}

// A Stanford2D3D root: one panorama in each of area_1 and area_5a (16-bit depth in 1/512 m,
// 65535 missing along the top rows).
inline std::filesystem::path write_stanford2d3d(const std::string& name) {
  const std::filesystem::path root = fresh_process_dir(name);
  const int64_t width = 32, height = 16;
  for (const std::string area : {"area_1", "area_5a"}) {
    const std::string stem = "camera_0a1b_" + area + "_office_1_frame_equirectangular_domain_";
    const std::filesystem::path pano = root / area / "pano";
    std::filesystem::create_directories(pano / "rgb");
    std::filesystem::create_directories(pano / "depth");
    io::write_image_png((pano / "rgb" / (stem + "rgb.png")).string(),
                        (at::arange(height * width * 3, at::kLong).view({height, width, 3}) * 5)
                            .remainder(256)
                            .to(at::kByte));
    at::Tensor code = at::arange(height * width, at::kLong).view({height, width}) * 3 + 700;
    code.narrow(0, 0, 2).fill_(65535);
    io::write_image_png((pano / "depth" / (stem + "depth.png")).string(), code.to(at::kInt));
  }
  return root;
}

}  // namespace omnipoint::test
