// The photo's own camera: camera_from_exif's closed forms (the 35 mm equivalent on the frame's
// diagonal; the focal length with the sensor's pixel density), and the predict job on JPEG files
// whose EXIF segment the test writes: the EXIF focal length becomes the camera (camera.json's
// camera_source "exif"), use_exif = false and a given camera take precedence, the Orientation
// turns the image, and a given camera is compared with the rays the network predicts.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/exif.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/predict_job.h"
#include "predict/tiny_model.h"
#include "support/cli_run.h"
#include "support/exif_jpeg.h"
#include "support/scratch_dir.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

const double kFilmDiagonal = std::sqrt(36.0 * 36.0 + 24.0 * 24.0);  // 43.27 mm

void expect_pinhole(const camera::Camera& camera, int64_t width, int64_t height, double focal) {
  EXPECT_EQ(camera.model_name(), "PINHOLE");
  EXPECT_EQ(camera.width(), width);
  EXPECT_EQ(camera.height(), height);
  const std::vector<double> expected = {focal, focal, 0.5 * width, 0.5 * height};
  ASSERT_EQ(camera.params().size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i)
    EXPECT_NEAR(camera.params()[i], expected[i], 1e-9 * expected[i]) << i;
}

TEST(ExifCamera, The35mmEquivalentSpansTheFramesDiagonal) {
  io::ExifFacts facts;
  facts.focal_length_35mm = 28;
  facts.make = "Maker";
  facts.model = "Phone";
  std::string rejected;
  const auto camera = camera_from_exif(facts, 4000, 3000, &rejected);
  ASSERT_TRUE(camera.has_value());
  // 5000 pixels of diagonal for 43.27 mm of film.
  expect_pinhole(camera->camera, 4000, 3000, 28.0 * 5000.0 / kFilmDiagonal);
  EXPECT_EQ(camera->description, "35 mm equivalent focal length 28 mm (Maker Phone)");
  EXPECT_TRUE(rejected.empty());
  // The diagonal does not turn with the picture; and it takes precedence over the focal length.
  facts.orientation = 6;
  facts.focal_length = 4.2;
  facts.focal_plane_pixels_per_mm = 100;
  expect_pinhole(camera_from_exif(facts, 3000, 4000)->camera, 3000, 4000,
                 28.0 * 5000.0 / kFilmDiagonal);
}

TEST(ExifCamera, TheFocalLengthTimesTheSensorsPixelDensity) {
  io::ExifFacts facts;
  facts.focal_length = 4.2;
  facts.focal_plane_pixels_per_mm = 100;  // 420 pixels at the density's own width
  expect_pinhole(camera_from_exif(facts, 2000, 1500)->camera, 2000, 1500, 420.0);
  // The density counts pixels of a 4000-pixel-wide image: this one was halved since.
  facts.pixel_x_dimension = 4000;
  expect_pinhole(camera_from_exif(facts, 2000, 1500)->camera, 2000, 1500, 210.0);
  // Turned by 90 degrees: the stored width is the displayed height.
  facts.orientation = 8;
  expect_pinhole(camera_from_exif(facts, 1500, 2000)->camera, 1500, 2000, 210.0);
  // A focal length without the density gives no camera.
  facts.focal_plane_pixels_per_mm.reset();
  EXPECT_FALSE(camera_from_exif(facts, 2000, 1500).has_value());
}

TEST(ExifCamera, AnImplausibleFieldOfViewIsRejectedWithItsReason) {
  io::ExifFacts facts;
  facts.focal_length_35mm = 1;  // 173 degrees across a 4:3 picture
  std::string rejected;
  EXPECT_FALSE(camera_from_exif(facts, 400, 300, &rejected).has_value());
  EXPECT_EQ(rejected.rfind("the EXIF 35 mm equivalent focal length 1 mm gives a horizontal "
                           "field of view of ",
                           0),
            0u)
      << rejected;
  rejected.clear();
  EXPECT_FALSE(camera_from_exif(io::ExifFacts{}, 400, 300, &rejected).has_value());
  EXPECT_TRUE(rejected.empty());
}

class ExifPredict : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!io::exif_available()) GTEST_SKIP() << "built without libexif";
    dir_ = test::fresh_process_dir(
        "omnipoint_exif_predict_" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  }
  void TearDown() override { fs::remove_all(dir_); }
  // A width x height JPEG with the EXIF segment of `tags`.
  std::string photo(const std::string& name, int width, int height,
                    const test::ExifTags& tags) const {
    cv::Mat pixels(height, width, CV_8UC3);
    cv::randu(pixels, cv::Scalar::all(0), cv::Scalar::all(255));
    std::vector<unsigned char> jpeg;
    cv::imencode(".jpg", pixels, jpeg);
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary)
        << test::jpeg_with_exif(std::string(jpeg.begin(), jpeg.end()), tags);
    return path;
  }
  PredictJobOptions options(const std::string& image, const std::string& out) const {
    PredictJobOptions job;
    job.inputs = {image};
    job.model_path = tiny_model_path();
    job.num_tokens = 12;
    job.output_dir = (dir_ / out).string();
    return job;
  }
  nlohmann::json camera_json(const std::string& out, const std::string& name) const {
    return nlohmann::json::parse(io::read_file((dir_ / out / name / "camera.json").string()));
  }

  struct Recorder : PredictJobObserver {
    std::vector<std::string> lines;
    std::vector<std::string> warnings;
    void image_written(const ImageEntry& image, const PredictedImage& predicted) override {
      lines.push_back(describe(image, predicted));
    }
    void warning(const ImageEntry&, const std::string& text) override { warnings.push_back(text); }
  };
  fs::path dir_;
};

TEST_F(ExifPredict, The35mmFocalLengthBecomesTheCamera) {
  test::ExifTags tags;
  tags.focal_length_35mm = 28;
  const std::string jpg = photo("photo.jpg", 56, 42, tags);
  Recorder recorder;
  ASSERT_EQ(PredictJob(options(jpg, "exif"), &recorder).Run().written, 1);
  const nlohmann::json json = camera_json("exif", "photo");
  EXPECT_EQ(json["camera_source"], "exif");
  const camera::Camera camera = camera::parse_camera(json["camera_spec"].get<std::string>());
  expect_pinhole(camera, 56, 42, 28.0 * 70.0 / kFilmDiagonal);
  // The rays are that camera's.
  const at::Tensor rays = io::read_npy((dir_ / "exif" / "photo" / "rays.npy").string());
  EXPECT_TRUE(at::allclose(rays, camera.ray_map().rays, 1e-5, 1e-6));
  const std::vector<std::string> notes = json["notes"];
  ASSERT_FALSE(notes.empty());
  EXPECT_EQ(notes[0],
            "camera from EXIF: 35 mm equivalent focal length 28 mm, a pinhole centred in the "
            "image (--no-exif: predicted instead)");
  ASSERT_EQ(recorder.lines.size(), 1u);
  EXPECT_NE(recorder.lines[0].find(", camera exif PINHOLE hfov "), std::string::npos)
      << recorder.lines[0];
  // The tiny OmniPoint network predicts rays of its own: their angle to the camera's is reported.
  ASSERT_TRUE(json.contains("camera_vs_network_rays_deg"));
  EXPECT_GE(json["camera_vs_network_rays_deg"]["median"].get<double>(), 0.0);
  EXPECT_LE(json["camera_vs_network_rays_deg"]["median"].get<double>(), 180.0);
  EXPECT_NE(recorder.lines[0].find(" deg from it (mean/median)"), std::string::npos)
      << recorder.lines[0];
}

TEST_F(ExifPredict, NoExifAndAGivenCameraTakePrecedence) {
  test::ExifTags tags;
  tags.focal_length_35mm = 28;
  const std::string jpg = photo("photo.jpg", 56, 42, tags);
  PredictJobOptions without = options(jpg, "without");
  without.use_exif = false;
  ASSERT_EQ(PredictJob(without).Run().written, 1);
  const nlohmann::json predicted = camera_json("without", "photo");
  EXPECT_NE(predicted.value("camera_source", ""), "exif");
  EXPECT_FALSE(predicted.contains("camera_vs_network_rays_deg"));
  for (const std::string note : predicted["notes"]) EXPECT_EQ(note.find("EXIF"), std::string::npos);

  PredictJobOptions given = options(jpg, "given");
  given.camera = "PINHOLE 56 42 30 30 28 21";
  Recorder recorder;
  ASSERT_EQ(PredictJob(given, &recorder).Run().written, 1);
  const nlohmann::json json = camera_json("given", "photo");
  EXPECT_EQ(json["camera_source"], "given");
  EXPECT_EQ(json["camera_spec"], "PINHOLE 56 42 30 30 28 21");
  EXPECT_TRUE(json.contains("camera_vs_network_rays_deg"));
  EXPECT_NE(recorder.lines[0].find(", camera given PINHOLE hfov "), std::string::npos)
      << recorder.lines[0];
}

TEST_F(ExifPredict, TheOrientationTurnsTheImageAsViewersShowIt) {
  test::ExifTags tags;
  tags.orientation = 6;  // stored 56x42, shown turned 90 degrees clockwise: 42x56
  tags.big_endian = true;
  const std::string jpg = photo("turned.jpg", 56, 42, tags);
  ASSERT_EQ(PredictJob(options(jpg, "turned")).Run().written, 1);
  const at::Tensor written = io::read_image((dir_ / "turned" / "turned" / "image.png").string());
  const at::Tensor stored = io::read_image(jpg);
  ASSERT_EQ(written.sizes(), (at::IntArrayRef{56, 42, 3}));
  // The top row shown is the stored left column, read bottom to top.
  EXPECT_TRUE(at::allclose(written, stored.transpose(0, 1).flip({1}), 0, 0.5 / 255));
  const std::vector<std::string> notes = camera_json("turned", "turned")["notes"];
  ASSERT_FALSE(notes.empty());
  EXPECT_EQ(notes[0],
            "EXIF orientation 6 applied (turned 90 degrees clockwise): the image as photo "
            "viewers show it");
  PredictJobOptions as_stored = options(jpg, "stored");
  as_stored.use_exif = false;
  ASSERT_EQ(PredictJob(as_stored).Run().written, 1);
  EXPECT_EQ(io::read_image((dir_ / "stored" / "turned" / "image.png").string()).sizes(),
            (at::IntArrayRef{42, 56, 3}));
}

TEST_F(ExifPredict, AnImplausibleFocalLengthIsAWarning) {
  test::ExifTags tags;
  tags.focal_length_35mm = 1;
  Recorder recorder;
  const PredictJobSummary summary =
      PredictJob(options(photo("wide.jpg", 56, 42, tags), "wide"), &recorder).Run();
  EXPECT_EQ(summary.written, 1);
  EXPECT_EQ(summary.warnings, 1);
  ASSERT_EQ(recorder.warnings.size(), 1u);
  EXPECT_NE(recorder.warnings[0].find("ignored"), std::string::npos) << recorder.warnings[0];
  EXPECT_NE(camera_json("wide", "wide").value("camera_source", ""), "exif");
}

// MoGe-2 predicts rays of its own on a pinhole: a given camera is compared with them.
TEST_F(ExifPredict, AGivenCameraIsComparedWithMoGe2sRays) {
  PredictJobOptions job = options(photo("plain.jpg", 56, 42, {}), "moge");
  job.model_path = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/model.safetensors";
  job.num_tokens = 300;
  job.fov_deg = 60;
  ASSERT_EQ(PredictJob(job).Run().written, 1);
  const nlohmann::json json = camera_json("moge", "plain");
  EXPECT_EQ(json["camera_source"], "given");
  ASSERT_TRUE(json.contains("camera_vs_network_rays_deg"));
  const nlohmann::json& angle = json["camera_vs_network_rays_deg"];
  EXPECT_GT(angle["mean"].get<double>(), 0.0);  // random weights: they differ
  EXPECT_LE(angle["median"].get<double>(), angle["max"].get<double>());
}

TEST_F(ExifPredict, TheCommandLineNamesTheCameraAndNoExifTurnsItOff) {
  test::ExifTags tags;
  tags.focal_length_35mm = 50;
  photo("photo.jpg", 56, 42, tags);
  const std::string model = " --model '" + tiny_model_path() + "' --num-tokens 12";
  const test::CliRun with =
      test::run_command("cd '" + dir_.string() + "' && '" + OMNIPOINT_CLI +
                            "' predict photo.jpg --out with --outputs camera" + model,
                        dir_ / "run");
  ASSERT_EQ(with.status, 0) << with.err;
  EXPECT_NE(with.err.find(", camera exif PINHOLE hfov "), std::string::npos) << with.err;
  EXPECT_EQ(camera_json("with", "photo")["camera_source"], "exif");
  const test::CliRun without =
      test::run_command("cd '" + dir_.string() + "' && '" + OMNIPOINT_CLI +
                            "' predict photo.jpg --no-exif --out without --outputs camera" + model,
                        dir_ / "run");
  ASSERT_EQ(without.status, 0) << without.err;
  EXPECT_EQ(without.err.find("camera exif"), std::string::npos) << without.err;
  EXPECT_NE(camera_json("without", "photo").value("camera_source", ""), "exif");
}

}  // namespace
}  // namespace omnipoint::predict
