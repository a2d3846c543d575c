// Camera files we write parse back exactly (cameras.txt for every model, predict's
// camera.json), and UniK3D's camera JSON is read as our models with hand-checked values.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "camera/sample_cameras.h"
#include "omnipoint/camera/camera.h"
#include "support/expect_error.h"

namespace omnipoint::camera {
namespace {

using test::expect_error;

void expect_bad_file(const std::string& text, const std::vector<std::string>& parts,
                     std::optional<ImageSize> size = std::nullopt) {
  expect_error<std::invalid_argument>([&] { parse_camera_file(text, "cam.json", "", size); },
                                      parts);
}

TEST(CamerasTxt, EveryModelRoundTripsExactly) {
  for (const auto& spec : testing::sample_camera_specs()) {
    const Camera camera = parse_camera(spec);
    const std::string text = to_cameras_txt(camera, 7);
    EXPECT_EQ(text.rfind("# Camera list with one line of data per camera:\n", 0), 0u) << text;
    EXPECT_NE(text.find("\n7 " + camera.to_spec() + "\n"), std::string::npos) << text;
    EXPECT_EQ(parse_camera_file(text, "cameras.txt"), camera) << spec;
    EXPECT_EQ(parse_camera_file(text, "cameras.txt", "7"), camera) << spec;
    EXPECT_EQ(parse_camera(cameras_txt_line(camera)), camera) << spec;
  }
  const Camera pinhole = parse_camera("PINHOLE 64 48 50 51 32 24");
  EXPECT_EQ(cameras_txt_line(pinhole), "1 PINHOLE 64 48 50 51 32 24");
  EXPECT_EQ(to_cameras_txt(pinhole),
            "# Camera list with one line of data per camera:\n"
            "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
            "# Number of cameras: 1\n"
            "1 PINHOLE 64 48 50 51 32 24\n");
}

// The shape predict writes (predict/outputs.h; tests/predict/test_camera_round_trip.cpp writes
// the real file): the camera is the object under "camera".
TEST(PredictCameraJson, CameraObjectIsRead) {
  const Camera camera = parse_camera("OPENCV_FISHEYE 64 48 20.25 20 32 24 0.01 0 0 0");
  const std::string text = R"({"camera": )" + camera.to_json() + R"(, "camera_spec": ")" +
                           camera.to_spec() + R"(", "metric_scale": 1.0, "notes": []})";
  EXPECT_EQ(parse_camera_file(text, "camera.json"), camera);
  EXPECT_EQ(parse_camera(text), camera);
}

TEST(PredictCameraJson, NullCameraSaysWhy) {
  expect_bad_file(R"({"camera": null, "fit_error": "fit_camera: needs at least 16 valid rays"})",
                  {"cam.json", "holds no camera", "at least 16 valid rays"});
  expect_bad_file(R"({"camera": null, "metric_scale": 1})", {"cam.json", "holds no camera"});
  expect_bad_file(R"({"camera": {"model": "PINHOLE"}})", {"cam.json", "expected {\"model\""});
  expect_bad_file(R"({"camera": 3})", {"cam.json", "camera.json written by predict"});
}

// UniK3D's pixel centres are ours (i + 0.5), so a Pinhole's principal point is unchanged.
TEST(Unik3dCamera, PinholeKeepsThePrincipalPoint) {
  const std::string text = R"({"name": "Pinhole", "params": [500.5, 501, 320, 240.25]})";
  const Camera camera = parse_camera_file(text, "cam.json", "", ImageSize{640, 480});
  EXPECT_EQ(camera, parse_camera("PINHOLE 640 480 500.5 501 320 240.25"));
  // The image centre's pixel (319, 239) has its centre at (319.5, 239.5): the ray through it
  // is K^-1 (319.5, 239.5, 1), as UniK3D's unproject of its coords_grid gives.
  const Rays ray = camera.unproject(at::tensor({319.5, 239.5}, at::kDouble));
  const double x = (319.5 - 320) / 500.5, y = (239.5 - 240.25) / 501;
  const double n = std::sqrt(x * x + y * y + 1);
  EXPECT_NEAR(ray.rays[0].item<double>(), x / n, 1e-15);
  EXPECT_NEAR(ray.rays[1].item<double>(), y / n, 1e-15);
  // A size in the file wins over none given.
  EXPECT_EQ(parse_camera_file(R"({"name": "Pinhole", "params": [500.5, 501, 320, 240.25],
                                  "width": 640, "height": 480})",
                              "cam.json"),
            camera);
}

TEST(Unik3dCamera, OpencvBecomesOpencvWithTheTangentialTermsSwapped) {
  // UniK3D's p1 (index 10) multiplies r² + 2x² in x: OpenCV's p2.
  const std::string tangential =
      R"({"name": "OPENCV", "params": [400, 401, 320, 240, 0, 0, 0, 0, 0, 0, 0.001, -0.002,
                                      0, 0, 0, 0]})";
  EXPECT_EQ(parse_camera_file(tangential, "cam.json", "", ImageSize{640, 480}),
            parse_camera("OPENCV 640 480 400 401 320 240 0 0 -0.002 0.001"));
  const std::string radial =
      R"({"name": "OPENCV", "params": [400, 401, 320, 240, -0.1, 0.02, 0, 0, 0, 0, 0, 0,
                                      0, 0, 0, 0]})";
  EXPECT_EQ(parse_camera_file(radial, "cam.json", "", ImageSize{640, 480}),
            parse_camera("OPENCV 640 480 400 401 320 240 -0.1 0.02 0 0"));
  const std::string k3 =
      R"({"name": "OPENCV", "params": [400, 401, 320, 240, -0.1, 0.02, 0.003, 0, 0, 0, 0, 0,
                                      0, 0, 0, 0]})";
  EXPECT_EQ(parse_camera_file(k3, "cam.json", "", ImageSize{640, 480}),
            parse_camera("FULL_OPENCV 640 480 400 401 320 240 -0.1 0.02 0 0 0.003 0 0 0"));
}

// UniK3D's tangential formula on the undistorted point, hand-evaluated: u = fx (x + 2 p2 x y +
// p1 (r² + 2 x²)) + cx in its naming, which our OPENCV reproduces.
TEST(Unik3dCamera, OpencvTangentialProjectsAsUnik3dDoes) {
  const Camera camera = parse_camera_file(
      R"({"name": "OPENCV", "params": [400, 401, 320, 240, 0, 0, 0, 0, 0, 0, 0.001, -0.002,
                                      0, 0, 0, 0]})",
      "cam.json", "", ImageSize{640, 480});
  const double x = 0.3, y = -0.2, r2 = x * x + y * y, p0 = 0.001, p1 = -0.002;
  const double u = 400 * (x + (2 * x * x + r2) * p0 + 2 * x * y * p1) + 320;
  const double v = 401 * (y + (2 * y * y + r2) * p1 + 2 * x * y * p0) + 240;
  const Pixels pixel = camera.project(at::tensor({x, y, 1.0}, at::kDouble));
  EXPECT_NEAR(pixel.pixels[0].item<double>(), u, 1e-9);
  EXPECT_NEAR(pixel.pixels[1].item<double>(), v, 1e-9);
}

TEST(Unik3dCamera, Fisheye624) {
  // UniK3D's scannet demo (assets/demo/scannet.json): only k0..k3 -> OPENCV_FISHEYE.
  const std::string scannet = R"({"params": [791.90869140625, 792.7230834960938,
      878.16796875, 585.045166015625, -0.029167557135224342, -0.006803446915000677,
      -0.0012682401575148106, -4.6094228309812024e-05, 0, 0, 0, 0, 0, 0, 0, 0],
      "name": "Fisheye624"})";
  EXPECT_EQ(parse_camera_file(scannet, "cam.json", "", ImageSize{1752, 1168}),
            make_camera("OPENCV_FISHEYE", 1752, 1168,
                        {791.90869140625, 792.7230834960938, 878.16796875, 585.045166015625,
                         -0.029167557135224342, -0.006803446915000677, -0.0012682401575148106,
                         -4.6094228309812024e-05}));
  // Any other term: RAD_TAN_THIN_PRISM_FISHEYE, whose parameter order is Fisheye624's.
  EXPECT_EQ(parse_camera_file(R"({"name": "Fisheye624", "params": [300, 301, 320, 240, 0.01,
                                  -0.002, 0.0003, 0, 0.00001, 0, 0.0004, -0.0002, 0.0001, 0,
                                  -0.0001, 0]})",
                              "cam.json", "", ImageSize{640, 480}),
            parse_camera("RAD_TAN_THIN_PRISM_FISHEYE 640 480 300 301 320 240 0.01 -0.002 0.0003 0 "
                         "0.00001 0 0.0004 -0.0002 0.0001 0 -0.0001 0"));
}

// UniK3D's Fisheye624 and MEI projections, evaluated by hand from unik3d/utils/camera.py,
// against ours for the cameras they map to.
TEST(Unik3dCamera, ProjectionsAreUnik3ds) {
  const double x = 0.4, y = -0.3, z = 0.8;
  const auto expect_pixel = [&](const Camera& camera, double u, double v) {
    const Pixels pixel = camera.project(at::tensor({x, y, z}, at::kDouble));
    ASSERT_TRUE(pixel.valid.item<bool>()) << camera.to_spec();
    EXPECT_NEAR(pixel.pixels[0].item<double>(), u, 1e-9) << camera.to_spec();
    EXPECT_NEAR(pixel.pixels[1].item<double>(), v, 1e-9) << camera.to_spec();
  };
  {
    const double k[6] = {0.01, -0.002, 0.0003, 0.0001, 0.00001, -0.000002};
    const double p0 = 0.0004, p1 = -0.0002, s0 = 0.0001, s1 = 0.00002, s2 = -0.0001, s3 = 0.00003;
    const Camera camera = parse_camera_file(
        R"({"name": "Fisheye624", "params": [300, 301, 320, 240, 0.01, -0.002, 0.0003, 0.0001,
            0.00001, -0.000002, 0.0004, -0.0002, 0.0001, 0.00002, -0.0001, 0.00003]})",
        "cam.json", "", ImageSize{640, 480});
    const double a = x / z, b = y / z, r = std::hypot(a, b), th = std::atan(r);
    double th_k = th;
    for (int i = 0; i < 6; ++i) th_k += k[i] * std::pow(th, 3 + 2 * i);
    const double xr = th_k * a / r, yr = th_k * b / r, rd2 = xr * xr + yr * yr;
    const double ud = xr + (2 * xr * xr + rd2) * p0 + 2 * xr * yr * p1 + s0 * rd2 + s1 * rd2 * rd2;
    const double vd = yr + (2 * yr * yr + rd2) * p1 + 2 * xr * yr * p0 + s2 * rd2 + s3 * rd2 * rd2;
    expect_pixel(camera, 300 * ud + 320, 301 * vd + 240);
  }
  {
    const double p0 = 0.0004, p1 = -0.0002, xi = 1.3;
    const Camera camera = parse_camera_file(
        R"({"name": "MEI", "params": [400, 401, 320, 240, 0, 0, 0.0004, -0.0002, 1.3]})",
        "cam.json", "", ImageSize{640, 480});
    const double norm = std::sqrt(x * x + y * y + z * z);
    const double a = x / (z + xi * norm), b = y / (z + xi * norm), r2 = a * a + b * b;
    expect_pixel(camera, 400 * (a + (2 * a * a + r2) * p0 + 2 * a * b * p1) + 320,
                 401 * (b + (2 * b * b + r2) * p1 + 2 * a * b * p0) + 240);
  }
}

TEST(Unik3dCamera, MeiEucmAndSpherical) {
  // MEI: xi moves from last to fifth, UniK3D's p1 p2 swap (as OPENCV's).
  EXPECT_EQ(parse_camera_file(
                R"({"name": "MEI", "params": [890, 891, 477, 470, 0, 0, 0.0004, 0.0002, 2.2]})",
                "cam.json", "", ImageSize{960, 940}),
            parse_camera("MEI 960 940 890 891 477 470 2.2 0 0 0.0002 0.0004"));
  EXPECT_EQ(parse_camera_file(
                R"({"name": "MEI", "params": [890, 891, 477, 470, 0.0168, 1.65, 0, 0, 2.2]})",
                "cam.json", "", ImageSize{960, 940}),
            parse_camera("MEI 960 940 890 891 477 470 2.2 0.0168 1.65 0 0"));
  EXPECT_EQ(parse_camera_file(R"({"name": "EUCM", "params": [180, 181, 320, 240, 0.6, 1.1]})",
                              "cam.json", "", ImageSize{640, 480}),
            parse_camera("EUCM 640 480 180 181 320 240 0.6 1.1"));
  // UniK3D's equirectangular demo: the size is in the parameters, hfov/2 and vfov/2 bound the
  // longitudes and latitudes; no size needs to be given.
  const Camera panorama = parse_camera_file(
      R"({"name": "Spherical", "params": [1.0, 1.0, 1.0, 1.0, 612.0, 277.0, 3.14159,
                                         1.42192880719]})",
      "cam.json");
  EXPECT_EQ(panorama, make_camera("EQUIRECTANGULAR", 612, 277,
                                  {-3.14159, 3.14159, -1.42192880719, 1.42192880719}));
  // Its centre pixel looks straight ahead, its top row up by vfov/2 less half a pixel.
  const Rays centre = panorama.unproject(at::tensor({306.0, 138.5}, at::kDouble));
  EXPECT_NEAR(centre.rays[2].item<double>(), 1.0, 1e-12);
  const Rays top = panorama.unproject(at::tensor({306.0, 0.5}, at::kDouble));
  const double elevation = 1.42192880719 - 0.5 * 2 * 1.42192880719 / 277;
  EXPECT_NEAR(top.rays[1].item<double>(), -std::sin(elevation), 1e-12);
}

TEST(Unik3dCamera, RefusesWhatItCannotRepresent) {
  const ImageSize size{640, 480};
  // UniK3D's dl3dv demo: radial and tangential terms together.
  expect_bad_file(R"({"name": "OPENCV", "params": [429.5, 429.6, 479.5, 269.5, -0.0014, 0.0007,
                      0, 0, 0, 0, 0.00012, 0.0011, 0, 0, 0, 0]})",
                  {"cam.json", "UniK3D OPENCV", "both radial (k1 k2 k3) and tangential (p1 p2)"},
                  size);
  expect_bad_file(R"({"name": "MEI", "params": [890, 891, 477, 470, 0.0168, 1.65, 0.0004,
                      0.0004, 2.2]})",
                  {"UniK3D MEI", "both radial (k1 k2) and tangential (p1 p2)"}, size);
  expect_bad_file(R"({"name": "OPENCV", "params": [400, 400, 320, 240, 0, 0, 0, 0, 0, 0, 0, 0,
                      0.001, 0, 0, 0]})",
                  {"UniK3D OPENCV", "thin-prism terms s1..s4"}, size);
  expect_bad_file(R"({"name": "OPENCV", "params": [400, 400, 320, 240, 0, 0, 0, 0.1, 0, 0, 0, 0,
                      0, 0, 0, 0]})",
                  {"UniK3D OPENCV", "rational terms k4..k6"}, size);
  expect_bad_file(R"({"name": "Pinhole", "params": [400, 400, 320]})",
                  {"cam.json", "UniK3D Pinhole expects 4 params (fx fy cx cy), got 3"}, size);
  expect_bad_file(R"({"name": "Pinhole", "params": [400, 400, 320, 240]})",
                  {"cam.json", "UniK3D Pinhole", "holds no image size"});
  expect_bad_file(R"({"name": "Spherical", "params": [1, 1, 1, 1, 612.5, 277, 3.14, 1.4]})",
                  {"UniK3D Spherical", "positive integers", "612.5"});
  expect_bad_file(R"({"name": "Kannala", "params": [1, 2]})",
                  {"cam.json", "unknown UniK3D camera class 'Kannala'", "Fisheye624"}, size);
  expect_bad_file(R"({"name": "Pinhole", "params": [-400, 400, 320, 240]})",
                  {"cam.json", "PINHOLE"}, size);
  expect_bad_file(R"({"name": 3, "params": [1]})", {"cam.json", "UniK3D camera"}, size);
}

}  // namespace
}  // namespace omnipoint::camera
