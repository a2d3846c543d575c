// Every format of the format table (dataset_formats.h) through `data check` and `data convert`:
// a small stand-in root in the format's native layout (one or two tiny items), checked (every
// item found and readable, the camera models expected, labels present unless the format has
// none) and converted to sample folders that reopen with "folders" as the same cameras and
// distances. A format added to the table without a stand-in here fails, naming it.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/imgcodecs.hpp>
#endif

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "driving_files.h"
#include "hdf5_files.h"
#include "kitti_calibration_files.h"
#include "native_roots.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/dataset_check.h"
#include "omnipoint/data/dataset_convert.h"
#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/moge_format.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "rig_log_files.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::write_text;

// A stand-in root: where and how to open it, and what `data check` must find there.
struct StandIn {
  DatasetLocation location;
  int64_t items = 0;
  std::set<std::string> camera_models;
  bool labelled = true;
  std::string unavailable = {};  // why this build cannot write the format ("" when it can)
};

// A colour image (H, W, 3) uint8 with a pattern.
at::Tensor pattern(int64_t height, int64_t width, int64_t seed = 0) {
  return (at::arange(height * width * 3, at::kLong).view({height, width, 3}) * 7 + seed)
      .remainder(256)
      .to(at::kByte);
}

void write_png(const fs::path& path, const at::Tensor& image) {
  fs::create_directories(path.parent_path());
  io::write_image_png(path.string(), image);
}

// A 16-bit grey PNG of codes (H, W) (int32 in [0, 65535]).
void write_png16(const fs::path& path, const at::Tensor& codes) {
  write_png(path, codes.to(at::kInt));
}

// Codes rising from `first` by `step` over the pixels, 0 (or `missing`) on the first row.
at::Tensor ramp_codes(int64_t height, int64_t width, int64_t first, int64_t step,
                      int64_t missing = 0) {
  at::Tensor codes = at::arange(height * width, at::kLong).view({height, width}) * step + first;
  codes.narrow(0, 0, 1).fill_(missing);
  return codes;
}

const char* const kPinhole = "PINHOLE 24 18 20 20 12 9";

StandIn folders(const fs::path& root) {
  for (uint64_t seed : {1, 2})
    write_sample(
        (root / ("sample_" + std::to_string(seed))).string(),
        synth::synthesize(synth::SceneKind::kObject, seed, camera::parse_camera(kPinhole)).sample);
  return {{root.string()}, 2, {"PINHOLE"}};
}

StandIn moge(const fs::path& root) {
  fs::create_directories(root / "a");
  // PNG bytes in image.jpg: the reader decodes by content.
  io::write_image_png((root / "a" / "image.jpg").string(), pattern(12, 16));
  write_moge_depth((root / "a" / "depth.png").string(), at::full({12, 16}, 2.5F));
  write_text(root / "a" / "meta.json",
             R"({"intrinsics": [[0.75, 0, 0.5], [0, 1.0, 0.5], [0, 0, 1]]})");
  write_text(root / ".index.txt", "a\n");
  return {{root.string(), true}, 1, {"PINHOLE"}};
}

StandIn kitti_raw(const fs::path&) {
  return {{test::write_kitti_raw("omnipoint_every_format_kitti_raw", 2).string()}, 2, {"PINHOLE"}};
}

StandIn kitti360(const fs::path& root) {
  const test::Kitti360Calibration calibration;
  calibration.write(root);
  const std::string sequence = "2013_05_28_drive_0000_sync";
  const camera::Camera fisheye = calibration.fisheye(2);
  const at::Tensor pixels =
      at::tensor({31.25, 32.75, 10.75, 20.25, 50.25, 12.25}, at::kDouble).view({3, 2});
  const at::Tensor points =
      fisheye.unproject(pixels).rays * at::tensor({5.5, 9.0, 14.25}, at::kDouble).view({3, 1});
  // image_02's frame -> the Velodyne's, through the pose frame (calib_cam_to_velo's chain).
  const at::Tensor velo_from_camera =
      at::matmul(at::inverse(calibration.body_from_velo), calibration.pose_from_camera(2));
  test::write_sweep(
      root / "data_3d_raw" / sequence / "velodyne_points" / "data" / (test::frame_stem(0) + ".bin"),
      test::transformed(velo_from_camera, points));
  write_png(
      root / "data_2d_raw" / sequence / "image_02" / "data_rgb" / (test::frame_stem(0) + ".png"),
      pattern(64, 64));
  return {{root.string()}, 1, {"MEI"}};
}

StandIn rig_log(const fs::path& root) {
  test::write_rig_log(root);
  return {{root.string()}, 2, {"PINHOLE", "OPENCV_FISHEYE"}};
}

StandIn stanford2d3d(const fs::path&) {
  return {{test::write_stanford2d3d("omnipoint_every_format_stanford2d3d").string()},
          2,
          {"EQUIRECTANGULAR"}};
}

StandIn matterport360(const fs::path& root) {
  const std::string id = "0b22fa63d0f54a529c525afbf2e8bb25";
  write_png(root / "17DRP5sb8fy" / "pano_skybox_color" / (id + ".jpg"), pattern(16, 32));
  write_png16(root / "17DRP5sb8fy" / "pano_depth" / (id + ".png"), ramp_codes(16, 32, 4000, 9));
  return {{root.string()}, 1, {"EQUIRECTANGULAR"}};
}

StandIn pano3d(const fs::path& root) {
#ifdef OMNIPOINT_WITH_OPENCV
  if (cv::haveImageWriter(".exr")) {
    write_png(root / "2t7WUuJeko7" / "0_spherical_1_emission_center_0.png", pattern(16, 32));
    cv::Mat depth(16, 32, CV_32FC1);
    for (int row = 0; row < 16; ++row)
      for (int column = 0; column < 32; ++column)
        depth.at<float>(row, column) =
            row == 0 ? std::numeric_limits<float>::infinity() : 1.5f + 0.125f * column;
    EXPECT_TRUE(
        cv::imwrite((root / "2t7WUuJeko7" / "0_spherical_1_depth_center_0.exr").string(), depth));
    return {{root.string()}, 1, {"EQUIRECTANGULAR"}};
  }
#endif
  StandIn none;
  none.unavailable = "this build writes no OpenEXR";
  return none;
}

StandIn panosuncg(const fs::path& root) {
  const fs::path folder = root / "rotated" / "3e2ce3b4d1e0b9f2a4c1f7d5c8e9a0b1" / "5.txt";
  write_png(folder / "12_color.png", pattern(16, 32));
  // 8-bit, three equal channels, value * 10 / 255 m; 0 no geometry.
  const at::Tensor code = ramp_codes(16, 32, 20, 1).clamp_max(255).to(at::kByte);
  write_png(folder / "12_depth.png", code.unsqueeze(-1).expand({16, 32, 3}).contiguous());
  return {{root.string()}, 1, {"EQUIRECTANGULAR"}};
}

StandIn structured3d(const fs::path& root) {
  const fs::path folder = root / "scene_00012" / "2D_rendering" / "485142" / "panorama" / "full";
  write_png(folder / "rgb_rawlight.png", pattern(16, 32));
  write_png16(folder / "depth.png", ramp_codes(16, 32, 1500, 7));  // millimetres
  return {{root.string()}, 1, {"EQUIRECTANGULAR"}};
}

StandIn hypersim(const fs::path& root) {
#ifdef OMNIPOINT_WITH_HDF5
  constexpr int64_t width = 16, height = 12;
  // metadata_camera_parameters.csv's columns the reader takes, the standard camera's row.
  write_text(root / "metadata_camera_parameters.csv",
             "scene_name,settings_output_img_height,settings_output_img_width,"
             "settings_units_info_meters_scale,use_camera_physical,camera_physical_anisotropy,"
             "M_cam_from_uv_00,M_cam_from_uv_01,M_cam_from_uv_02,M_cam_from_uv_10,"
             "M_cam_from_uv_11,M_cam_from_uv_12,M_cam_from_uv_20,M_cam_from_uv_21,"
             "M_cam_from_uv_22,M_proj_00\n"
             "ai_001_001,12.0,16.0,0.02539999969303608,False,,0.5773502886169104,0,0,0,"
             "0.4330127164626828,0,0,0,-1,1.7320507492870254\n");
  const fs::path images = root / "ai_001_001" / "images";
  at::Tensor distance = 2.0 + at::arange(height * width, at::kFloat).view({height, width}) / 64;
  distance.narrow(0, 0, 1).fill_(std::numeric_limits<float>::quiet_NaN());
  test::write_float16(images / "scene_cam_00_geometry_hdf5" / "frame.0000.depth_meters.hdf5",
                      distance);
  test::write_int16(images / "scene_cam_00_geometry_hdf5" / "frame.0000.render_entity_id.hdf5",
                    at::full({height, width}, 7, at::kInt));
  test::write_float16(images / "scene_cam_00_final_hdf5" / "frame.0000.color.hdf5",
                      pattern(height, width).to(at::kFloat) / 255);
  return {{root.string()}, 1, {"PINHOLE"}};
#else
  StandIn none;
  none.unavailable = "this build has no HDF5";
  return none;
#endif
}

StandIn vkitti2(const fs::path& root) {
  const fs::path frames = root / "Scene01" / "clone" / "frames";
  write_text(
      root / "Scene01" / "clone" / "intrinsic.txt",
      "frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n0 0 20 20 15.5 7.5\n0 1 20 20 15.5 7.5\n");
  write_png(frames / "rgb" / "Camera_0" / "rgb_00000.jpg", pattern(16, 32));
  // Centimetre z-depth, 65535 the sky.
  write_png16(frames / "depth" / "Camera_0" / "depth_00000.png",
              ramp_codes(16, 32, 300, 11, 65535));
  return {{root.string()}, 1, {"PINHOLE"}};
}

StandIn arkitscenes(const fs::path& root) {
  const fs::path video = root / "Training" / "41069021";
  const std::string stem = "41069021_6845.873";
  write_png(video / "lowres_wide" / (stem + ".png"), pattern(18, 24));
  write_png16(video / "lowres_depth" / (stem + ".png"), ramp_codes(18, 24, 800, 5));  // mm
  write_text(video / "lowres_wide_intrinsics" / (stem + ".pincam"), "24 18 20 20 11.5 8.5\n");
  return {{root.string()}, 1, {"PINHOLE"}};
}

StandIn tartanair(const fs::path& root) {
  // The dataset's one camera: 640 x 480.
  const fs::path trajectory = root / "abandonedfactory" / "Easy" / "P000";
  write_png(trajectory / "image_left" / "000000_left.png", pattern(480, 640));
  at::Tensor depth = 1.0 + at::arange(480 * 640, at::kFloat).view({480, 640}) / 4096;
  depth.narrow(0, 0, 1).fill_(10000);  // the sky sphere
  fs::create_directories(trajectory / "depth_left");
  io::write_npy((trajectory / "depth_left" / "000000_left_depth.npy").string(), depth);
  return {{root.string()}, 1, {"PINHOLE"}};
}

StandIn images(const fs::path& root) {
  write_png(root / "a.png", pattern(20, 20));
  write_png(root / "trip" / "b.png", pattern(20, 20, 3));
  StandIn stand_in{{root.string()}, 2, {"OPENCV_FISHEYE"}, false};
  stand_in.location.options["camera"] = "OPENCV_FISHEYE 20 20 9 9 10 10 0 0 0 0";
  return stand_in;
}

const std::map<std::string, std::function<StandIn(const fs::path&)>> kStandIns = {
    {"folders", folders},
    {"moge", moge},
    {"kitti-raw", kitti_raw},
    {"kitti360", kitti360},
    {"rig-log", rig_log},
    {"stanford2d3d", stanford2d3d},
    {"matterport360", matterport360},
    {"pano3d", pano3d},
    {"panosuncg", panosuncg},
    {"structured3d", structured3d},
    {"hypersim", hypersim},
    {"vkitti2", vkitti2},
    {"arkitscenes", arkitscenes},
    {"tartanair", tartanair},
    {"images", images}};

TEST(EveryFormat, ChecksAndConvertsItsStandInRoot) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path scratch = test::fresh_process_dir("omnipoint_every_format");
  const std::vector<std::string> registered = dataset_formats();
  for (const DatasetFormat& format : builtin_dataset_formats()) {
    SCOPED_TRACE(format.name);
    EXPECT_NE(std::find(registered.begin(), registered.end(), format.name), registered.end());
    const auto stand_in_of = kStandIns.find(format.name);
    if (stand_in_of == kStandIns.end()) {
      ADD_FAILURE() << "format \"" << format.name
                    << "\" has no stand-in root in tests/data/test_every_format.cpp";
      continue;
    }
    const fs::path root = scratch / format.name;
    fs::create_directories(root);
    const StandIn stand_in = stand_in_of->second(root);
    if (!stand_in.unavailable.empty()) {
      std::cout << "[ note     ] " << format.name << ": not checked (" << stand_in.unavailable
                << ")\n";
      continue;
    }

    // data check: every item found and read, the cameras expected, labels where there are.
    DatasetCheckOptions check;
    check.format = format.name;
    check.location = stand_in.location;
    check.sheet_path = (scratch / (format.name + "_sheet.png")).string();
    const DatasetCheckReport report = DatasetCheck(check).Run();
    EXPECT_EQ(report.items, stand_in.items);
    EXPECT_EQ(report.read, stand_in.items);
    EXPECT_TRUE(report.missing.empty()) << report.missing.front();
    EXPECT_TRUE(report.failed.empty()) << report.failed.front();
    std::set<std::string> models;
    int64_t with_camera = 0;
    for (const auto& [model, count] : report.camera_models) {
      models.insert(model);
      with_camera += count;
    }
    EXPECT_EQ(models, stand_in.camera_models);
    EXPECT_EQ(with_camera, stand_in.items);
    if (stand_in.labelled) {
      EXPECT_GT(report.density_min, 0);
      EXPECT_GT(report.distance_min, 0);
      EXPECT_GE(report.distance_max, report.distance_min);
    } else {
      EXPECT_EQ(report.density_max, 0);
    }
    EXPECT_TRUE(fs::is_regular_file(check.sheet_path));

    // data convert: the same items as sample folders, each with its source's camera and
    // distances exactly.
    DatasetConvertOptions convert;
    convert.format = format.name;
    convert.location = stand_in.location;
    convert.output_path = (scratch / (format.name + "_converted")).string();
    const DatasetConvertReport converted = DatasetConvert(convert).Run();
    EXPECT_EQ(converted.converted, stand_in.items);
    EXPECT_TRUE(converted.skipped.empty()) << converted.skipped.front();
    // Each manifest line pairs a sample folder with the item it came from.
    const std::unique_ptr<Dataset> source = open_dataset(format.name, stand_in.location);
    std::map<std::string, int64_t> index_of;
    for (int64_t i = 0; i < source->size(); ++i) index_of[source->item_name({i, 0})] = i;
    EXPECT_EQ(open_dataset("folders", {convert.output_path})->size(), source->size());
    std::istringstream manifest(io::read_file(converted.manifest_path));
    int64_t lines = 0;
    for (std::string line; std::getline(manifest, line); ++lines) {
      const nlohmann::json entry = nlohmann::json::parse(line);
      const std::string what = entry.at("item").get<std::string>();
      ASSERT_EQ(index_of.count(what), 1u) << what;
      const Sample truth = source->item({index_of.at(what), 0});
      const Sample read = read_sample(
          (fs::path(convert.output_path) / entry.at("sample").get<std::string>()).string());
      EXPECT_EQ(read.camera, truth.camera) << what;
      EXPECT_TRUE(at::equal(read.distance, truth.distance)) << what;
      EXPECT_TRUE(at::equal(read.mask, truth.mask)) << what;
    }
    EXPECT_EQ(lines, stand_in.items);
  }
  fs::remove_all(scratch);
}

}  // namespace
}  // namespace omnipoint::data
