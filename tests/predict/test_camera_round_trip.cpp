// Cameras out = cameras in (issue 14): the camera.json and cameras.txt predict writes are read
// back by --camera as the identical camera, a given camera comes back unchanged, and a fitted
// one reports its residual.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/fit.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"
#include "predict/tiny_model.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("omnipoint_camera_round_trip_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A prediction whose rays are the camera's, written out; returns the folder.
fs::path write_for(const camera::Camera& camera, const std::string& name, bool fitted) {
  const camera::Rays rays = camera.ray_map();
  Prediction p = prediction_from_geometry(
      rays.rays, at::full({camera.height(), camera.width()}, 3.0), rays.valid);
  if (fitted) {
    const camera::CameraFit fit =
        camera::fit_camera_auto(camera.width(), camera.height(), p.rays, p.mask);
    p.fitted_camera = fit.camera;
    p.fit_residual = fit.residual;
  } else {
    p.fitted_camera = camera;
  }
  const fs::path folder = fresh_dir(name) / "image";
  write_prediction_outputs(folder.string(), at::rand({camera.height(), camera.width(), 3}), p);
  return folder;
}

TEST(CameraRoundTrip, WrittenFilesReadBackAsTheSameCamera) {
  for (const std::string spec : {"OPENCV_FISHEYE 48 40 15.25 15.5 24.5 19.75 0.02 -0.01 0.001 0",
                                 "EQUIRECTANGULAR 64 32 -1.5 1.5 -0.7 0.8"}) {
    const camera::Camera camera = camera::parse_camera(spec);
    const fs::path folder = write_for(camera, "given", false);
    const camera::Camera from_json = io::read_camera((folder / "camera.json").string());
    const camera::Camera from_txt = io::read_camera((folder / "cameras.txt").string());
    EXPECT_EQ(from_json, camera) << spec;
    EXPECT_EQ(from_txt, camera) << spec;
    EXPECT_EQ(io::read_camera((folder / "cameras.txt").string() + "#1"), camera) << spec;
    EXPECT_TRUE(at::equal(from_json.ray_map().rays, camera.ray_map().rays)) << spec;
    const auto json = nlohmann::json::parse(io::read_file((folder / "camera.json").string()));
    EXPECT_EQ(json["camera_source"], "given");
    EXPECT_FALSE(json.contains("fit_residual_deg"));
    EXPECT_EQ(json["cameras_txt_line"], "1 " + camera.to_spec());
    EXPECT_EQ(camera::parse_camera(json["cameras_txt_line"].get<std::string>()), camera);
    EXPECT_EQ(camera::parse_camera(json["camera_spec"].get<std::string>()), camera);
  }
}

TEST(CameraRoundTrip, FittedCameraReportsItsResidual) {
  const camera::Camera truth = camera::parse_camera("PINHOLE 64 48 40 41 32.5 23.5");
  const fs::path folder = write_for(truth, "fitted", true);
  const auto json = nlohmann::json::parse(io::read_file((folder / "camera.json").string()));
  EXPECT_EQ(json["camera_source"], "fitted");
  EXPECT_EQ(json["camera"]["model"], "PINHOLE");
  EXPECT_LT(json["fit_residual_deg"]["median"].get<double>(), 1e-3);
  EXPECT_LT(json["fit_residual_deg"]["max"].get<double>(), 1e-3);
  EXPECT_GE(json["fit_residual_deg"]["max"].get<double>(),
            json["fit_residual_deg"]["median"].get<double>());
  const camera::Camera fitted = io::read_camera((folder / "camera.json").string());
  EXPECT_EQ(io::read_camera((folder / "cameras.txt").string()), fitted);
}

TEST(CameraRoundTrip, NoCameraFileSaysWhy) {
  const camera::Rays rays = camera::parse_camera("PINHOLE 8 8 8 8 4 4").ray_map();
  Prediction p =
      prediction_from_geometry(rays.rays, at::ones({8, 8}), at::zeros({8, 8}, at::kBool));
  p.fit_error = "fit_camera_auto: needs at least 16 valid rays, got 0";
  const fs::path folder = fresh_dir("none") / "image";
  write_prediction_outputs(folder.string(), at::rand({8, 8, 3}), p);
  EXPECT_FALSE(fs::exists(folder / "cameras.txt"));
  try {
    io::read_camera((folder / "camera.json").string());
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("holds no camera"), std::string::npos) << message;
    EXPECT_NE(message.find("needs at least 16 valid rays"), std::string::npos) << message;
  }
}

class PredictCamera : public ::testing::Test {
 protected:
  static const Model& model() {
    static const Model loaded = Model::load(tiny_model_path());
    return loaded;
  }
  const at::Tensor image = at::rand({32, 32, 3}, at::make_generator<at::CPUGeneratorImpl>(7));
  PredictOptions options_with(const std::optional<camera::Camera>& camera) const {
    PredictOptions options;
    options.num_tokens = 12;
    options.camera = camera;
    // The residual is checked against the shipped mask, which the flying-pixel filter (applied
    // after the fit) would otherwise thin out.
    options.edge_rtol = 0;
    return options;
  }
};

// The case: a given fisheye came back re-fitted (fx 94.3 for 100).
TEST_F(PredictCamera, GivenCameraComesBackUnchanged) {
  const camera::Camera given = camera::parse_camera("OPENCV_FISHEYE 32 32 10 10 16 16 0.01 0 0 0");
  const Prediction p = model().predict(image, options_with(given));
  ASSERT_TRUE(p.fitted_camera.has_value()) << p.fit_error;
  EXPECT_EQ(*p.fitted_camera, given);
  EXPECT_FALSE(p.fit_residual.has_value());
  // The output rays are the camera's where valid (where the lens sees).
  const camera::Rays rays = given.ray_map();
  EXPECT_TRUE(at::equal(p.rays.index({p.mask}), rays.rays.index({p.mask})));
  EXPECT_LT(camera::angular_residual(*p.fitted_camera, p.rays, p.mask).max_deg, 1e-4);  // float32
  // Given at another size of the image's aspect: reported at the image's size.
  const Prediction resized = model().predict(image, options_with(given.resized(64, 64)));
  ASSERT_TRUE(resized.fitted_camera.has_value());
  EXPECT_EQ(*resized.fitted_camera, given.resized(64, 64).resized(32, 32));
  // Asked for another model: that model is fitted to the rays, with its residual.
  PredictOptions pinhole = options_with(given);
  pinhole.fit_model = "PINHOLE";
  const Prediction forced = model().predict(image, pinhole);
  ASSERT_TRUE(forced.fitted_camera.has_value()) << forced.fit_error;
  EXPECT_EQ(forced.fitted_camera->model_name(), "PINHOLE");
  ASSERT_TRUE(forced.fit_residual.has_value());
  EXPECT_GT(forced.fit_residual->max_deg, 0.1);
}

// Without a camera the fit is reported with its residual, and feeding its camera.json back
// gives predictions on exactly that camera's rays, with that camera reported.
TEST_F(PredictCamera, FittedCameraFedBackIsUsedAsItIs) {
  const Prediction first = model().predict(image, options_with(std::nullopt));
  ASSERT_TRUE(first.fitted_camera.has_value()) << first.fit_error;
  ASSERT_TRUE(first.fit_residual.has_value());
  const camera::AngularResidual residual = camera::angular_residual(
      *first.fitted_camera, first.rays, first.mask & (first.rays.norm(2, -1) > 0.5));
  EXPECT_NEAR(first.fit_residual->median_deg, residual.median_deg, 1e-9);
  EXPECT_NEAR(first.fit_residual->max_deg, residual.max_deg, 1e-9);

  const fs::path folder = fresh_dir("fed_back") / "image";
  write_prediction_outputs(folder.string(), image, first);
  const camera::Camera read = io::read_camera((folder / "camera.json").string());
  EXPECT_EQ(read, *first.fitted_camera);
  const Prediction second = model().predict(image, options_with(read));
  ASSERT_TRUE(second.fitted_camera.has_value());
  EXPECT_EQ(*second.fitted_camera, read);
  const camera::Rays rays = read.ray_map();
  EXPECT_TRUE(at::equal(second.rays.index({second.mask}), rays.rays.index({second.mask})));
}

}  // namespace
}  // namespace omnipoint::predict
