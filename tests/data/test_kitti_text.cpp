// The driving-log text parsers (io/keyed_text.h, data/formats/kitti_text.h), the LiDAR label
// rules (data/formats/lidar_labels.h) and the sparse-label flag of a sample (sample.h,
// transform.h): closed-form cases and bad inputs.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/formats/kitti_text.h"
#include "omnipoint/data/formats/lidar_labels.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/io/keyed_text.h"

namespace omnipoint::data {
namespace {

std::string error_of(const std::function<void()>& run) {
  try {
    run();
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "(no std::invalid_argument)";
}

void expect_error(const std::function<void()>& run, const std::vector<std::string>& parts) {
  const std::string error = error_of(run);
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  for (const std::string& part : parts) EXPECT_NE(error.find(part), std::string::npos) << error;
}

TEST(KeyedText, KeysInOrderWordsAllowedNumbersChecked) {
  const io::KeyedText keyed = io::KeyedText::parse(
      "calib_time: 09-Jan-2012 13:57:47\r\n\nR: 1 0 0 0 1 0 0 0 1\nT: -4.0e-03 0.5 7\n", "f");
  EXPECT_EQ(keyed.keys(), (std::vector<std::string>{"calib_time", "R", "T"}));
  EXPECT_TRUE(keyed.has("T"));
  EXPECT_FALSE(keyed.has("Tr"));
  EXPECT_EQ(keyed.numbers("T", 3), (std::vector<double>{-4.0e-03, 0.5, 7}));
  expect_error([&] { keyed.numbers("T", 2); }, {"f", "T", "expected 2 numbers, got 3"});
  expect_error([&] { keyed.numbers("calib_time"); }, {"f calib_time", "09-Jan-2012"});
  expect_error([&] { keyed.numbers("P_rect_02"); }, {"f", "no key P_rect_02"});
  expect_error([] { io::KeyedText::parse("R: 1\nR: 2\n", "g"); }, {"g", "R appears twice"});
  expect_error([] { io::KeyedText::parse("R 1 2\n", "g"); }, {"g", "\"R 1 2\"", "KEY: values"});
  expect_error([] { io::KeyedText::parse("T: 1 nan 2\n", "g").numbers("T"); }, {"nan"});
}

// A calib_cam_to_cam.txt of two cameras: camera 2 with P = K [I | t] and R_rect_00 a rotation.
const char* const kCamToCam =
    "calib_time: 09-Jan-2012 13:57:47\n"
    "S_rect_00: 1.242000e+03 3.750000e+02\n"
    "R_rect_00: 0 -1 0 1 0 0 0 0 1\n"
    "P_rect_00: 7.215377e+02 0 6.095593e+02 0 0 7.215377e+02 1.728540e+02 0 0 0 1 0\n"
    "S_rect_02: 1.242000e+03 3.750000e+02\n"
    "P_rect_02: 700 0 600 4.485728e+01 0 710 170 2.163791e-01 0 0 1 2.745884e-03\n";

TEST(KittiText, RawCameraIsTheRectifiedPinholeAndItsOffset) {
  const KittiRawCamera cam =
      parse_kitti_raw_camera(kCamToCam, "c", "image_02", PrincipalPoint::kIntegerCentre);
  EXPECT_EQ(cam.camera.to_spec(), "PINHOLE 1242 375 700 710 600.5 170.5");
  // camera_from_cam0 = [I | t] · R_rect_00 with K t = P[:, 3].
  const double tz = 2.745884e-03, ty = (2.163791e-01 - 170 * tz) / 710,
               tx = (4.485728e+01 - 600 * tz) / 700;
  const at::Tensor expected =
      at::tensor({0.0, -1.0, 0.0, tx, 1.0, 0.0, 0.0, ty, 0.0, 0.0, 1.0, tz, 0.0, 0.0, 0.0, 1.0},
                 at::kDouble)
          .view({4, 4});
  EXPECT_TRUE(at::allclose(cam.camera_from_cam0, expected, 0, 1e-12)) << cam.camera_from_cam0;
  EXPECT_EQ(
      parse_kitti_raw_camera(kCamToCam, "c", "image_00", PrincipalPoint::kCorner).camera.to_spec(),
      "PINHOLE 1242 375 721.5377 721.5377 609.5593 172.854");
  expect_error([] { parse_kitti_raw_camera(kCamToCam, "c", "image_03", {}); },
               {"c", "no key S_rect_03"});
  expect_error([] { parse_kitti_raw_camera(kCamToCam, "c", "image_2", {}); }, {"image_2"});
  expect_error(
      [] {
        parse_kitti_raw_camera(
            "S_rect_02: 10 10\nR_rect_00: 1 0 0 0 1 0 0 0 1\n"
            "P_rect_02: 7 1 5 0 0 7 5 0 0 0 1 0\n",
            "c", "image_02", {});
      },
      {"c", "P_rect_02", "rectified projection"});
  expect_error([] { parse_kitti_raw_camera("S_rect_02: 10.5 10\n", "c", "image_02", {}); },
               {"c", "S_rect_02", "whole image size"});
}

TEST(KittiText, RawSplitListInMonodepthForm) {
  const std::vector<KittiRawListEntry> entries = parse_kitti_raw_list(
      "2011_09_26/2011_09_26_drive_0002_sync 69 l\n\n2011_09_26/d 3 r\n2011_09_26/d 0000000005\n",
      "list");
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[0].drive, "2011_09_26/2011_09_26_drive_0002_sync");
  EXPECT_EQ(entries[0].frame, 69);
  EXPECT_EQ(entries[0].camera, "image_02");
  EXPECT_EQ(entries[1].line, 3);
  EXPECT_EQ(entries[1].camera, "image_03");
  EXPECT_EQ(entries[2].frame, 5);
  EXPECT_EQ(entries[2].camera, "");
  expect_error([] { parse_kitti_raw_list("d 1 x\n", "list"); }, {"list", "line 1", "l or r"});
  expect_error([] { parse_kitti_raw_list("d -1\n", "list"); }, {"line 1", "-1"});
  expect_error([] { parse_kitti_raw_list("d\n", "list"); }, {"line 1", "2 or 3 fields"});
  expect_error([] { parse_kitti_raw_list("../d 1\n", "list"); }, {"leaves the root"});
  expect_error([] { parse_kitti_raw_list("\n", "list"); }, {"list", "no frame"});
}

// calibration/image_02.yaml as KITTI-360's calibration.zip has it, one line "key:value" without
// the space (the devkit's reader accepts both).
const char* const kFisheyeYaml =
    "%YAML:1.0\n"
    "model_type: MEI\n"
    "camera_name: image_02\n"
    "image_width: 1400\n"
    "image_height:1400\n"
    "mirror_parameters:\n"
    "   xi: 2.2134047507854890e+00\n"
    "distortion_parameters:\n"
    "   k1: 1.6798235660113681e-02\n"
    "   k2: 1.6548773243373522e+00\n"
    "   p1: 4.2223943394772046e-04\n"
    "   p2: 4.2462134260997584e-04\n"
    "projection_parameters:\n"
    "   gamma1: 1.3363220825849971e+03\n"
    "   gamma2: 1.3357883350012958e+03\n"
    "   u0: 7.1694323510126321e+02\n"
    "   v0: 7.0576498308221585e+02\n";

TEST(KittiText, Kitti360FisheyeYamlAsMei) {
  const camera::Camera cam =
      parse_kitti360_fisheye(kFisheyeYaml, "y", PrincipalPoint::kIntegerCentre, false);
  EXPECT_EQ(cam.model_name(), "MEI");
  EXPECT_EQ(cam.width(), 1400);
  EXPECT_EQ(cam.height(), 1400);
  const std::vector<double> expected = {1.3363220825849971e+03,
                                        1.3357883350012958e+03,
                                        7.1694323510126321e+02 + 0.5,
                                        7.0576498308221585e+02 + 0.5,
                                        2.2134047507854890e+00,
                                        1.6798235660113681e-02,
                                        1.6548773243373522e+00,
                                        0.0,
                                        0.0};
  EXPECT_EQ(cam.params(), expected);
  const camera::Camera dac =
      parse_kitti360_fisheye(kFisheyeYaml, "y", PrincipalPoint::kCorner, true);
  EXPECT_EQ(dac.params()[2], 7.1694323510126321e+02);
  EXPECT_EQ(dac.params()[7], 4.2223943394772046e-04);
  EXPECT_EQ(dac.params()[8], 4.2462134260997584e-04);
  // The devkit's projection (datasets.md: n = X/|X|, x = n_x / (n_z + xi), radial k1, k2,
  // u = gamma1 x + u0) lands at our u - 0.5.
  const double X = 1.0, Y = -0.5, Z = 2.0, norm = std::sqrt(X * X + Y * Y + Z * Z);
  const double xi = 2.2134047507854890e+00, k1 = 1.6798235660113681e-02,
               k2 = 1.6548773243373522e+00;
  double x = (X / norm) / (Z / norm + xi), y = (Y / norm) / (Z / norm + xi);
  const double r2 = x * x + y * y, radial = 1 + k1 * r2 + k2 * r2 * r2;
  x *= radial;
  y *= radial;
  const at::Tensor pixel = cam.project(at::tensor({X, Y, Z}, at::kDouble)).pixels;
  EXPECT_NEAR(pixel[0].item<double>() - 0.5, 1.3363220825849971e+03 * x + 7.1694323510126321e+02,
              1e-6);
  EXPECT_NEAR(pixel[1].item<double>() - 0.5, 1.3357883350012958e+03 * y + 7.0576498308221585e+02,
              1e-6);

  std::string other = kFisheyeYaml;
  other.replace(other.find("MEI"), 3, "KANNALA_BRANDT");
  expect_error([&] { parse_kitti360_fisheye(other, "y", {}, false); }, {"y", "KANNALA_BRANDT"});
  std::string missing = kFisheyeYaml;
  missing.erase(missing.find("   k2:"), missing.find("   p1:") - missing.find("   k2:"));
  expect_error([&] { parse_kitti360_fisheye(missing, "y", {}, false); },
               {"y", "no key distortion_parameters.k2"});
  std::string word = kFisheyeYaml;
  word.replace(word.find("2.2134047507854890e+00"), 22, "two");
  expect_error([&] { parse_kitti360_fisheye(word, "y", {}, false); },
               {"mirror_parameters.xi", "two"});
  expect_error([] { parse_kitti360_fisheye("model_type: MEI\nimage_width\n", "y", {}, false); },
               {"y", "line 2"});
}

TEST(KittiText, Kitti360PoseFilesAndLists) {
  const auto to_pose = parse_kitti360_cam_to_pose(
      "image_00: 1 0 0 1.5 0 1 0 0 0 0 1 -2\nimage_02: 0 0 1 0 -1 0 0 0 0 -1 0 0.5\n", "p");
  ASSERT_EQ(to_pose.size(), 2u);
  EXPECT_EQ(to_pose.at("image_00")[0][3].item<double>(), 1.5);
  EXPECT_EQ(to_pose.at("image_02")[2][1].item<double>(), -1.0);
  EXPECT_EQ(to_pose.at("image_02")[3][3].item<double>(), 1.0);
  expect_error([] { parse_kitti360_cam_to_pose("image_02: 1 0 0 0 0 1 0 0 0 0 1 0\n", "p"); },
               {"p", "no key image_00"});
  expect_error([] { parse_kitti360_cam_to_pose("image_00: 1 0 0\n", "p"); },
               {"p", "image_00", "expected 12 numbers, got 3"});

  const auto poses =
      parse_kitti360_poses("3 1 0 0 10 0 1 0 20 0 0 1 30\n\n7 1 0 0 1 0 1 0 2 0 0 1 3\n", "w");
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses.at(3)[1][3].item<double>(), 20.0);
  EXPECT_EQ(poses.at(7)[2][3].item<double>(), 3.0);
  expect_error([] { parse_kitti360_poses("3 1 0 0\n", "w"); }, {"w", "line 1", "13 numbers"});
  expect_error(
      [] { parse_kitti360_poses("1 1 0 0 0 0 1 0 0 0 0 1 0\n1 1 0 0 0 0 1 0 0 0 0 1 0\n", "w"); },
      {"w", "frame 1 appears twice"});
  expect_error([] { parse_kitti360_poses("2.5 1 0 0 0 0 1 0 0 0 0 1 0\n", "w"); },
               {"line 1", "no index"});

  const auto perspective = parse_kitti360_perspective(
      "S_rect_00: 1408 376\nR_rect_00: 1 0 0 0 0 -1 0 1 0\n"
      "P_rect_00: 552.55 0 682.05 0 0 552.55 238.77 0 0 0 1 0\n",
      "s", "image_00", PrincipalPoint::kIntegerCentre);
  EXPECT_EQ(perspective.camera.to_spec(), "PINHOLE 1408 376 552.55 552.55 682.55 239.27");
  EXPECT_EQ(perspective.rect_from_camera[1][2].item<double>(), -1.0);
  expect_error([] { parse_kitti360_perspective("", "s", "image_02", {}); },
               {"s", "image_02", "no perspective camera"});

  const auto list = parse_kitti360_list(
      "data_2d_raw/a/image_02/data_rgb/0000000000.png proj_depth/a/image_02/0000000000.png "
      "1336.3221\n\nimg.png\n",
      "l");
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].depth, "proj_depth/a/image_02/0000000000.png");
  EXPECT_EQ(list[1].line, 3);
  EXPECT_EQ(list[1].depth, "");
  expect_error([] { parse_kitti360_list("a b focal\n", "l"); }, {"l", "line 1", "IMAGE"});
  expect_error([] { parse_kitti360_list("", "l"); }, {"l", "no frame"});
}

TEST(LidarLabels, NearestPointOnItsPixelOrDacsTruncatedLastPoint) {
  const camera::Camera cam("PINHOLE", 8, 6, {4, 4, 4, 3});  // pixel (u, v) -> ray ((u-4)/4, ..)
  // Two points on pixel (5, 3) (projections (5.9, 3.7) and (5.6, 3.7): DAC's devkit
  // coordinates, ours minus 0.5, truncate to (5, 3) both), the far one last; one behind the
  // camera.
  const at::Tensor points = at::tensor({1.9 / 4 * 2, 0.7 / 4 * 2, 2.0,  //
                                        1.6 / 4 * 8, 0.7 / 4 * 8, 8.0,  //
                                        0.0, 0.0, -3.0},
                                       at::kDouble)
                                .view({3, 3});
  const double near = points[0].norm().item<double>(), far = points[1].norm().item<double>();
  const LidarLabels nearest = lidar_labels(points, cam);
  EXPECT_EQ(nearest.mask.sum().item<int64_t>(), 1);
  EXPECT_NEAR(nearest.distance[3][5].item<double>(), near, 1e-6);
  const LidarLabels dac = lidar_labels(points, cam, {LidarRule::kDac, 0.5, false});
  EXPECT_EQ(dac.mask.sum().item<int64_t>(), 1);
  EXPECT_NEAR(dac.distance[3][5].item<double>(), far, 1e-6);
  // With the devkit's rounding (its perspective projection) a point at devkit u = 5.6 (ours
  // 6.1) lands on pixel 6, as it does in ours.
  const at::Tensor rounded_point = at::tensor({2.1 / 4 * 2, 0.7 / 4 * 2, 2.0}, at::kDouble);
  EXPECT_TRUE(lidar_labels(rounded_point.view({1, 3}), cam, {LidarRule::kDac, 0.5, true})
                  .mask[3][6]
                  .item<bool>());
  EXPECT_TRUE(lidar_labels(rounded_point.view({1, 3}), cam).mask[3][6].item<bool>());
  expect_error([] { parse_lidar_rule("closest", "d"); }, {"d", "closest", "nearest or dac"});
  expect_error([] { parse_principal_point("centre", "d"); }, {"d", "centre"});
}

TEST(SparseLabels, MetaFlagRoundTripsAndResizingKeepsEverySample) {
  EXPECT_TRUE(parse_sample_meta(R"({"camera": "PINHOLE 8 8 4 4 4 4", "sparse_labels": true})", "m")
                  .sparse_labels);
  EXPECT_FALSE(parse_sample_meta(R"({"camera": "PINHOLE 8 8 4 4 4 4"})", "m").sparse_labels);
  try {
    parse_sample_meta(R"({"camera": "PINHOLE 8 8 4 4 4 4", "sparse_labels": "yes"})", "m");
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("sparse_labels"), std::string::npos);
  }

  // Samples on even pixels of an 8x8 map: nearest-neighbour picking at 4x4 reads odd pixels
  // (centres 2i + 1) and would keep none; a sparse resize moves each to the pixel holding its
  // centre.
  Sample sample{camera::Camera("PINHOLE", 8, 8, {4, 4, 4, 4}), at::zeros({8, 8, 3}),
                at::zeros({8, 8}), at::zeros({8, 8}, at::kBool), true};
  sample.distance[0][0] = 3.0;
  sample.distance[2][2] = 5.0;
  sample.distance[4][6] = 7.0;
  sample.mask = sample.distance > 0;
  sample.sparse_labels = true;
  const Sample sparse = resize_sample(sample, 4, 4);
  EXPECT_TRUE(sparse.sparse_labels);
  EXPECT_EQ(sparse.mask.sum().item<int64_t>(), 3);
  EXPECT_EQ(sparse.distance[0][0].item<float>(), 3.0f);
  EXPECT_EQ(sparse.distance[1][1].item<float>(), 5.0f);
  EXPECT_EQ(sparse.distance[2][3].item<float>(), 7.0f);
  sample.sparse_labels = false;
  EXPECT_EQ(resize_sample(sample, 4, 4).mask.sum().item<int64_t>(), 0);
  // Cropping keeps the flag.
  EXPECT_TRUE(crop_sample(sparse, 0, 0, 2, 2).sparse_labels);
}

}  // namespace
}  // namespace omnipoint::data
