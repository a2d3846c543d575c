// COLMAP sparse models written as COLMAP writes them (tests/support/colmap_writer.h), read back.
#include "omnipoint/io/colmap.h"

#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "support/colmap_writer.h"
#include "support/expect_error.h"
#include "support/scratch_dir.h"

namespace fs = std::filesystem;
using omnipoint::io::ColmapImage;
using omnipoint::io::ColmapModel;
using omnipoint::io::ColmapPoint;
using omnipoint::io::read_colmap_model;
using omnipoint::test::ColmapScene;
using omnipoint::test::expect_error;

namespace {

// Image 1: R = 90 degrees about z, t = (0.5, -0.5, 3), on PINHOLE camera 1; it sees point 7 at
// world (0.5, 0.25, 2): camera (-0.25 + 0.5, 0.5 - 0.5, 2 + 3) = (0.25, 0, 5), pixel
// (500 * 0.05 + 320, 240) = (345, 240). Image 2 (quaternion 2 0 0 0: identity once
// normalised, t = 0) on OPENCV camera 2 sees point 8 at (0, 0, 4) at its principal point and
// has one observation of no point. Image 3, a panorama with a space in its name, sees nothing.
ColmapScene scene() {
  ColmapScene s;
  s.cameras = {{1, "PINHOLE", 640, 480, {500, 510, 320, 240}},
               {2, "OPENCV", 320, 240, {250, 250, 160, 120, -0.1, 0.01, 0.001, -0.001}},
               {3, "EQUIRECTANGULAR", 64, 32, {64, 32}}};
  const double h = std::sqrt(0.5);
  ColmapImage one;
  one.id = 1;
  one.camera_id = 1;
  one.name = "frames/one.jpg";
  one.qvec = {h, 0, 0, h};
  one.tvec = {0.5, -0.5, 3};
  one.points2d = {{345, 240}};
  one.point3d_ids = {7};
  ColmapImage two;
  two.id = 2;
  two.camera_id = 2;
  two.name = "two.png";
  two.qvec = {2, 0, 0, 0};
  two.points2d = {{10.5, 20.25}, {160, 120}};
  two.point3d_ids = {-1, 8};
  ColmapImage three;
  three.id = 3;
  three.camera_id = 3;
  three.name = "pano 1.jpg";
  s.images = {one, two, three};
  s.points[7] = {{0.5, 0.25, 2}, {255, 128, 0}, 0.5};
  s.points[8] = {{0, 0, 4}, {1, 2, 3}, 1.25};
  return s;
}

class Colmap : public ::testing::Test {
 protected:
  fs::path dir_ = omnipoint::test::fresh_process_dir("omnipoint_colmap_test");
  void TearDown() override { fs::remove_all(dir_); }
};

void expect_scene(const ColmapModel& model) {
  ASSERT_EQ(model.cameras.size(), 3u);
  EXPECT_EQ(model.cameras.at(1),
            omnipoint::camera::parse_camera("PINHOLE 640 480 500 510 320 240"));
  EXPECT_EQ(model.cameras.at(2), omnipoint::camera::parse_camera(
                                     "OPENCV 320 240 250 250 160 120 -0.1 0.01 0.001 -0.001"));
  // COLMAP's EQUIRECTANGULAR w h = the image size is our full panorama.
  EXPECT_EQ(model.cameras.at(3), omnipoint::camera::parse_camera("EQUIRECTANGULAR 64 32"));
  ASSERT_EQ(model.images.size(), 3u);
  const ColmapImage& one = model.images[0];
  EXPECT_EQ(one.id, 1);
  EXPECT_EQ(one.camera_id, 1);
  EXPECT_EQ(one.name, "frames/one.jpg");
  EXPECT_EQ(model.images[2].name, "pano 1.jpg");
  EXPECT_TRUE(model.images[2].points2d.empty());
  const ColmapImage& two = model.images[1];
  EXPECT_DOUBLE_EQ(two.qvec[0], 1.0);  // normalised
  ASSERT_EQ(two.point3d_ids.size(), 2u);
  EXPECT_EQ(two.point3d_ids[0], -1);
  EXPECT_EQ(two.point3d_ids[1], 8);
  EXPECT_DOUBLE_EQ(two.points2d[0][0], 10.5);
  EXPECT_DOUBLE_EQ(two.points2d[0][1], 20.25);
  ASSERT_EQ(model.points.size(), 2u);
  const ColmapPoint& seven = model.points.at(7);
  EXPECT_DOUBLE_EQ(seven.xyz[1], 0.25);
  EXPECT_EQ(seven.rgb[1], 128);
  EXPECT_DOUBLE_EQ(seven.error, 0.5);
}

// The world point seen by `image` at its observation `index`, projected through its pose and
// camera.
at::Tensor reprojected(const ColmapModel& model, const ColmapImage& image, size_t index) {
  const auto& xyz = model.points.at(image.point3d_ids[index]).xyz;
  const at::Tensor world = at::tensor({xyz[0], xyz[1], xyz[2], 1.0}, at::kDouble);
  const at::Tensor in_camera = at::matmul(omnipoint::io::camera_from_world(image), world);
  return model.cameras.at(image.camera_id).project(in_camera.slice(0, 0, 3)).pixels;
}

void expect_reprojections(const ColmapModel& model) {
  for (const ColmapImage& image : {model.images[0], model.images[1]}) {
    const size_t index = image.point3d_ids.size() - 1;
    const at::Tensor pixel = reprojected(model, image, index);
    EXPECT_NEAR(pixel[0].item<double>(), image.points2d[index][0], 1e-9) << image.name;
    EXPECT_NEAR(pixel[1].item<double>(), image.points2d[index][1], 1e-9) << image.name;
  }
}

TEST_F(Colmap, ReadsTheTextModel) {
  omnipoint::test::write_colmap_text(dir_, scene());
  const ColmapModel model = read_colmap_model(dir_.string());
  expect_scene(model);
  expect_reprojections(model);
}

TEST_F(Colmap, ReadsTheBinaryModel) {
  omnipoint::test::write_colmap_binary(dir_, scene());
  const ColmapModel model = read_colmap_model(dir_.string());
  expect_scene(model);
  expect_reprojections(model);
}

TEST_F(Colmap, CameraFromWorldIsTheHandComputedPose) {
  const at::Tensor pose = omnipoint::io::camera_from_world(scene().images[0]);
  const at::Tensor expected =
      at::tensor({0.0, -1.0, 0.0, 0.5, 1.0, 0.0, 0.0, -0.5, 0.0, 0.0, 1.0, 3.0, 0.0, 0.0, 0.0, 1.0},
                 at::kDouble)
          .view({4, 4});
  EXPECT_TRUE(at::allclose(pose, expected, 0, 1e-15)) << pose;
}

TEST_F(Colmap, TextAndBinaryReadEqually) {
  omnipoint::test::write_colmap_text(dir_ / "text", scene());
  omnipoint::test::write_colmap_binary(dir_ / "binary", scene());
  const ColmapModel text = read_colmap_model((dir_ / "text").string());
  const ColmapModel binary = read_colmap_model((dir_ / "binary").string());
  EXPECT_EQ(text.cameras, binary.cameras);
  ASSERT_EQ(text.images.size(), binary.images.size());
  for (size_t i = 0; i < text.images.size(); ++i) {
    const ColmapImage &a = text.images[i], &b = binary.images[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.camera_id, b.camera_id);
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.qvec, b.qvec);  // 17 digits: exact
    EXPECT_EQ(a.tvec, b.tvec);
    EXPECT_EQ(a.points2d, b.points2d);
    EXPECT_EQ(a.point3d_ids, b.point3d_ids);
  }
  ASSERT_EQ(text.points.size(), binary.points.size());
  for (const auto& [id, point] : text.points) {
    EXPECT_EQ(point.xyz, binary.points.at(id).xyz);
    EXPECT_EQ(point.rgb, binary.points.at(id).rgb);
    EXPECT_EQ(point.error, binary.points.at(id).error);
  }
}

TEST_F(Colmap, PrefersBinaryFilesOverText) {
  ColmapScene other = scene();
  other.images[0].name = "from_binary.jpg";
  omnipoint::test::write_colmap_text(dir_, scene());
  omnipoint::test::write_colmap_binary(dir_, other);
  EXPECT_EQ(read_colmap_model(dir_.string()).images[0].name, "from_binary.jpg");
}

TEST_F(Colmap, TruncatedBinaryIsAnError) {
  std::string bytes = omnipoint::test::colmap_cameras_binary(scene());
  bytes.resize(bytes.size() - 3);
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_cameras_binary(bytes, "cams.bin"); },
      {"COLMAP cams.bin", "truncated: camera 3's parameter 1"});
  std::string images = omnipoint::test::colmap_images_binary(scene());
  images.resize(images.size() - 5);
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_images_binary(images, "images.bin"); },
      {"images.bin", "truncated: the number of image 3's points2D"});
}

TEST_F(Colmap, HugeCountsAreErrorsBeforeAnyAllocation) {
  std::string bytes = omnipoint::test::colmap_points_binary(scene());
  const uint64_t huge = uint64_t{1} << 60;
  std::memcpy(bytes.data(), &huge, 8);
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_points_binary(bytes, "points3D.bin"); },
      {"points3D.bin", "1152921504606846976 points declared", "bytes left hold"});
}

TEST_F(Colmap, UnknownAndUnsupportedModelsAreNamed) {
  std::string bytes = omnipoint::test::colmap_cameras_binary(scene());
  const int32_t unknown = 42, fisheye = 15;
  std::memcpy(bytes.data() + 12, &unknown, 4);  // the first camera's model id
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_cameras_binary(bytes, "cameras.bin"); },
      {"cameras.bin", "camera 1", "unknown COLMAP camera model id 42"});
  std::memcpy(bytes.data() + 12, &fisheye, 4);
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_cameras_binary(bytes, "cameras.bin"); },
      {"cameras.bin", "camera 1", "model FISHEYE is not supported"});
  expect_error<std::invalid_argument>(
      [&] {
        omnipoint::io::parse_colmap_cameras_text("1 SIMPLE_DIVISION 64 48 50 32 24 0.1\n",
                                                 "cameras.txt");
      },
      {"cameras.txt", "line 1", "SIMPLE_DIVISION is not supported"});
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_cameras_text("1 EQUIRECTANGULAR 64 32 60 32\n", "c.txt"); },
      {"c.txt", "EQUIRECTANGULAR parameters w h must be the image size 64 32"});
}

TEST_F(Colmap, ImageWithAnUnknownCameraIsAnError) {
  ColmapScene bad = scene();
  bad.images[1].camera_id = 9;
  omnipoint::test::write_colmap_binary(dir_, bad);
  expect_error<std::invalid_argument>(
      [&] { read_colmap_model(dir_.string()); },
      {"images.bin", "image 2 (two.png) uses camera 9", "cameras.bin lacks"});
}

TEST_F(Colmap, ObservationOfAMissingPointIsAnError) {
  ColmapScene bad = scene();
  bad.points.erase(8);
  omnipoint::test::write_colmap_text(dir_, bad);
  expect_error<std::invalid_argument>(
      [&] { read_colmap_model(dir_.string()); },
      {"images.txt", "image 2 (two.png) observes point 8", "points3D.txt lacks"});
}

TEST_F(Colmap, MissingFilesAreErrors) {
  expect_error<std::runtime_error>([&] { read_colmap_model((dir_ / "nope").string()); },
                                   {"nope", "not a folder"});
  omnipoint::test::write_colmap_text(dir_, scene());
  fs::remove(dir_ / "points3D.txt");
  expect_error<std::runtime_error>([&] { read_colmap_model(dir_.string()); },
                                   {"no points3D.bin or points3D.txt"});
}

TEST_F(Colmap, BadTextIsAnErrorNamingTheLine) {
  const std::string header = "# Image list with two lines of data per image:\n";
  expect_error<std::invalid_argument>(
      [&] {
        omnipoint::io::parse_colmap_images_text(header + "1 0 0 0 0 0 0 0 1 a.jpg\n\n",
                                                "images.txt");
      },
      {"images.txt", "image 1: the quaternion is zero"});
  expect_error<std::invalid_argument>(
      [&] {
        omnipoint::io::parse_colmap_images_text(header + "1 1 0 0 0 0 0 0 1 a.jpg\n", "im.txt");
      },
      {"im.txt", "line 2: image 1 has no POINTS2D line"});
  expect_error<std::invalid_argument>(
      [&] {
        omnipoint::io::parse_colmap_images_text(header + "1 1 0 0 0 0 0 0 1 a.jpg\n1 2 3 4\n",
                                                "im.txt");
      },
      {"im.txt", "line 3: POINTS2D holds 4 values"});
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_points_text("1 0 0 nan 1 2 3 0\n", "p.txt"); },
      {"p.txt", "line 1: X Y Z is not finite"});
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_points_text("1 0 0 1 1 2 300 0\n", "p.txt"); },
      {"p.txt", "colour 300 is not 0..255"});
  expect_error<std::invalid_argument>(
      [&] { omnipoint::io::parse_colmap_cameras_text("1 PINHOLE 64 48 50 50 32\n", "c.txt"); },
      {"c.txt", "line 1 (camera 1)", "PINHOLE expects 4 parameters"});
  expect_error<std::invalid_argument>(
      [&] {
        omnipoint::io::parse_colmap_cameras_text(
            "1 PINHOLE 64 48 50 50 32 24\n1 PINHOLE 64 48 50 50 32 24\n", "c.txt");
      },
      {"c.txt", "the camera id 1 appears twice"});
}

}  // namespace
