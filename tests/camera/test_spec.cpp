// Camera specs: every accepted form, and every error path with a message naming the model
// (or the input) and what it expects.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "omnipoint/camera/camera.h"
#include "support/expect_error.h"

namespace omnipoint::camera {
namespace {

using test::expect_error;

void expect_bad_spec(const std::string& spec, const std::vector<std::string>& parts) {
  expect_error<std::invalid_argument>([&] { parse_camera(spec); }, parts);
}

TEST(CameraSpec, ColmapLine) {
  const auto camera = parse_camera("  PINHOLE 640 480 500 501 320 240\n");
  EXPECT_EQ(camera.model_name(), "PINHOLE");
  EXPECT_EQ(camera.width(), 640);
  EXPECT_EQ(camera.height(), 480);
  EXPECT_EQ(camera.params(), (std::vector<double>{500, 501, 320, 240}));
  EXPECT_EQ(parse_camera("3 PINHOLE 640 480 500 501 320 240"), camera);
}

TEST(CameraSpec, Json) {
  const auto camera = parse_camera(R"({"model": "OPENCV", "width": 64, "height": 48,
                                       "params": [50, 50, 32, 24, -0.1, 0.01, 0, 0]})");
  EXPECT_EQ(camera.model_name(), "OPENCV");
  EXPECT_EQ(camera.params()[4], -0.1);
  EXPECT_EQ(parse_camera(camera.to_json()), camera);
}

TEST(CameraSpec, ToSpecRoundTripsExactly) {
  const auto camera =
      make_camera("OPENCV", 64, 48, {1.0 / 3, 0.1, 32.123456789012345, 24, -1e-17, 0.2, 0, 0});
  EXPECT_EQ(parse_camera(camera.to_spec()), camera);
  EXPECT_EQ(parse_camera(camera.to_json()), camera);
}

TEST(CameraSpec, CentredPinhole) {
  const auto camera = centred_pinhole(90, 640, 480);
  EXPECT_EQ(camera.model_name(), "PINHOLE");
  EXPECT_NEAR(camera.params()[0], 320, 1e-9);
  EXPECT_NEAR(camera.params()[1], 320, 1e-9);
  EXPECT_EQ(camera.params()[2], 320);
  EXPECT_EQ(camera.params()[3], 240);
  expect_error<std::invalid_argument>([] { centred_pinhole(180, 640, 480); },
                                      {"--fov", "(0, 180)"});
  expect_error<std::invalid_argument>([] { centred_pinhole(0, 640, 480); }, {"--fov"});
}

TEST(CameraSpec, RejectsBadTensorInput) {
  const auto camera = parse_camera("PINHOLE 64 48 50 50 32 24");
  expect_error<std::invalid_argument>(
      [&] {
        camera.unproject(at::zeros({4, 2}, at::kLong));
      },
      {"floating-point"});
  expect_error<std::invalid_argument>([&] { camera.unproject(at::zeros({4, 3})); }, {"(..., 2)"});
  expect_error<std::invalid_argument>([&] { camera.project(at::zeros({4, 2})); }, {"(..., 3)"});
}

TEST(CameraSpec, WrongParameterCount) {
  expect_bad_spec("PINHOLE 640 480 500 500 320",
                  {"PINHOLE", "expects 4 parameters (fx fy cx cy)", "got 3"});
  expect_bad_spec("EQUIRECTANGULAR 64 32 1 2", {"EQUIRECTANGULAR", "0 parameters", "or 4"});
  expect_bad_spec("OPENCV 64 48", {"OPENCV", "8 parameters"});
}

TEST(CameraSpec, UnknownModel) {
  expect_bad_spec("PINHOL 640 480 500 500 320 240",
                  {"unknown camera model 'PINHOL'", "PINHOLE", "OPENCV", "EQUIRECTANGULAR"});
  expect_bad_spec(R"({"model": "X", "width": 1, "height": 1, "params": []})",
                  {"unknown camera model 'X'"});
}

TEST(CameraSpec, NonFiniteOrNonNumeric) {
  expect_bad_spec("PINHOLE 640 480 nan 500 320 240", {"PINHOLE", "not finite", "fx fy cx cy"});
  expect_bad_spec("PINHOLE 640 480 inf 500 320 240", {"PINHOLE", "not finite"});
  expect_bad_spec("PINHOLE 640 480 5OO 500 320 240", {"PINHOLE", "not a number: '5OO'"});
  expect_bad_spec("PINHOLE 640.5 480 500 500 320 240", {"PINHOLE", "width must be an integer"});
}

TEST(CameraSpec, ImpossibleValues) {
  expect_bad_spec("PINHOLE 640 480 0 500 320 240", {"PINHOLE", "focal length fx must be > 0"});
  expect_bad_spec("SIMPLE_RADIAL 640 480 -5 320 240 0.1",
                  {"SIMPLE_RADIAL", "focal length f must be > 0"});
  expect_bad_spec("PINHOLE 0 480 500 500 320 240", {"PINHOLE", "image size must be positive"});
  expect_bad_spec("FOV 640 480 300 300 320 240 3.5", {"FOV", "omega must be in [0, pi)"});
  expect_bad_spec("EQUIRECTANGULAR 64 32 1 -1 0 1", {"EQUIRECTANGULAR", "lon_min < lon_max"});
  expect_bad_spec("EQUIRECTANGULAR 64 32 -1 1 0 2", {"EQUIRECTANGULAR", "lat_max <= pi/2"});
}

TEST(CameraSpec, BadJson) {
  expect_bad_spec(R"({"model": "PINHOLE", "width": 64)", {"not valid JSON"});
  expect_bad_spec(R"({"model": "PINHOLE", "width": 64, "height": 48})", {"expected {\"model\""});
  expect_bad_spec(R"({"model": "PINHOLE", "width": 64, "height": 48, "params": [1, "a", 3, 4]})",
                  {"params must be numbers"});
  expect_bad_spec(R"({"model": "PINHOLE", "width": 6.5, "height": 48, "params": [1, 1, 3, 4]})",
                  {"expected {\"model\""});
}

TEST(CameraSpec, EmptyOrUnrecognised) {
  expect_bad_spec("   ", {"empty camera spec"});
  // File names are io::read_camera's (tests/io/test_camera_file.cpp).
  expect_bad_spec("/no/such/cameras.txt", {"'/no/such/cameras.txt'", "not a camera line"});
}

}  // namespace
}  // namespace omnipoint::camera
