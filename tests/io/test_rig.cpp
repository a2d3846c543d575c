// Rig files (io/rig.h): every field read as written (rows as rows, a camera file relative to the
// rig's folder), a calibration printed to 7 digits accepted, and each bad field refused with one
// line naming it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <ATen/ATen.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "omnipoint/io/rig.h"

namespace omnipoint::io {
namespace {
namespace fs = std::filesystem;

// A forward pinhole looking along body x (camera z -> body x, camera x -> -body y, camera y ->
// -body z) 1.5 m ahead of the body origin and 1.2 m up; a fisheye from a camera file.
const char* const kCarRig = R"({"frame": "vehicle",
 "cameras": [
  {"name": "front", "camera": "PINHOLE 1920 1080 1000 1001 959.5 539.5",
   "body_from_camera": [[0, 0, 1, 1.5], [-1, 0, 0, 0], [0, -1, 0, 1.2]]},
  {"name": "left", "camera": "calib/cameras.txt#2",
   "body_from_camera": [[1, 0, 0, 0.5], [0, 0, 1, 0.9], [0, -1, 0, 1.0], [0, 0, 0, 1]]}],
 "lidar": {"format": "nuscenes", "body_from_lidar": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.7]]}})";

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

class RigFile : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() / ("omnipoint_rig_" + std::to_string(::getpid()));
    fs::create_directories(folder_ / "calib");
    write_text((folder_ / "calib" / "cameras.txt").string(),
               "1 PINHOLE 64 48 50 50 32 24\n2 MEI 1400 1400 600 601 699.5 699.5 0.9 0 0 0 0\n");
  }
  void TearDown() override { fs::remove_all(folder_); }
  fs::path folder_;
};

TEST_F(RigFile, ReadsEveryFieldAsWritten) {
  write_text((folder_ / "rig.json").string(), kCarRig);
  const Rig rig = read_rig((folder_ / "rig.json").string());
  EXPECT_EQ(rig.frame, "vehicle");
  ASSERT_EQ(rig.cameras.size(), 2u);

  const RigCamera& front = rig.cameras[0];
  EXPECT_EQ(front.name, "front");
  EXPECT_EQ(front.camera.to_spec(), "PINHOLE 1920 1080 1000 1001 959.5 539.5");
  ASSERT_EQ(front.body_from_camera.sizes(), (at::IntArrayRef{4, 4}));
  // Rows are rows: the optical axis (camera z) points along body x, the centre is t.
  const at::Tensor axis = front.body_from_camera.slice(0, 0, 3).slice(1, 0, 3).mv(
      at::tensor({0.0, 0.0, 1.0}, at::kDouble));
  EXPECT_TRUE(at::equal(axis, at::tensor({1.0, 0.0, 0.0}, at::kDouble))) << axis;
  const at::Tensor centre = front.body_from_camera.slice(0, 0, 3).select(1, 3);
  EXPECT_TRUE(at::equal(centre, at::tensor({1.5, 0.0, 1.2}, at::kDouble))) << centre;
  EXPECT_TRUE(at::equal(front.body_from_camera[3], at::tensor({0.0, 0.0, 0.0, 1.0}, at::kDouble)));

  const RigCamera& left = rig.cameras[1];
  EXPECT_EQ(left.camera.model_name(), "MEI");  // camera 2 of calib/cameras.txt, beside the rig
  EXPECT_EQ(left.camera.params()[1], 601.0);
  EXPECT_EQ(left.body_from_camera[2][3].item<double>(), 1.0);  // a 4x4 read as written
  EXPECT_EQ(rig.find("left"), &rig.cameras[1]);
  EXPECT_EQ(rig.find("rear"), nullptr);

  ASSERT_TRUE(rig.lidar.has_value());
  EXPECT_EQ(rig.lidar->format, "nuscenes");
  EXPECT_EQ(rig.lidar->floats_per_point, 5);
  EXPECT_EQ(rig.lidar->body_from_lidar[2][3].item<double>(), 1.7);
}

TEST_F(RigFile, FrameAndLidarAreOptionalAndAJsonCameraIsInline) {
  const Rig rig = parse_rig(
      R"({"cameras": [{"name": "pano", "camera": {"model": "EQUIRECTANGULAR", "width": 64,
          "height": 32, "params": []}, "body_from_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}]})",
      "rig.json", folder_.string());
  EXPECT_EQ(rig.frame, "body");
  EXPECT_FALSE(rig.lidar.has_value());
  EXPECT_EQ(rig.cameras[0].camera.model_name(), "EQUIRECTANGULAR");
  EXPECT_TRUE(at::equal(rig.cameras[0].body_from_camera, at::eye(4, at::kDouble)));
}

// A rotation of 30° about z printed to 7 significant digits (as calibration files print them)
// is orthonormal to about 1e-7: accepted; one entry off by 1e-3 is not.
TEST_F(RigFile, ACalibrationPrintedToSevenDigitsIsAcceptedAndAnOffRotationIsNot) {
  const auto rig_with = [&](const std::string& r00) {
    return parse_rig(R"({"cameras": [{"name": "a", "camera": "PINHOLE 64 48 50 50 32 24",
        "body_from_camera": [[)" +
                         r00 + R"(, -0.5, 0, 0], [0.5, 0.8660254, 0, 0], [0, 0, 1, 0]]}]})",
                     "rig.json", folder_.string());
  };
  EXPECT_NO_THROW(rig_with("0.8660254"));
  try {
    rig_with("0.8670254");
    FAIL() << "an off rotation was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(
        std::string(error.what())
            .rfind("rig.json: cameras[0].body_from_camera: the rotation is not orthonormal", 0),
        0u)
        << error.what();
  }
}

// One line naming the field for each kind of bad content.
TEST_F(RigFile, EachBadFieldIsOneLineNamingIt) {
  const std::string good_camera =
      R"("name": "a", "camera": "PINHOLE 64 48 50 50 32 24", )"
      R"("body_from_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]])";
  const std::string identity = "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]";
  const struct {
    std::string text, message;
  } cases[] = {
      {"[1, 2]", "rig.json: expected a JSON object"},
      {R"({"cameras": []})", "rig.json: cameras: expected a list of at least one camera"},
      {R"({"cameras": [{)" + good_camera + "}, {" + good_camera + "}]}",
       "rig.json: cameras[1].name: 'a' names another camera too"},
      {R"({"cameras": [{"name": "a", "camera": "PINHOLE 64 48 50 50 32 24"}]})",
       "rig.json: cameras[0].body_from_camera: missing"},
      {R"({"cameras": [{"name": "a/b", "camera": "PINHOLE 64 48 50 50 32 24", "body_from_camera": )" +
           identity + "}]}",
       "rig.json: cameras[0].name: expected letters, digits, '_', '-' or '.' (not first): it "
       "names files"},
      {R"({"cameras": [{"name": "a", "camera": "PINHOLE 64 48 50 50 32 24", "body_from_camera": [[1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}]})",
       "rig.json: cameras[0].body_from_camera: row 0: expected 4 numbers"},
      {R"({"cameras": [{"name": "a", "camera": "PINHOLE 64 48 50 50 32 24", "body_from_camera": [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}]})",
       "rig.json: cameras[0].body_from_camera: the rotation is a reflection (determinant -1)"},
      {R"({"cameras": [{"name": "a", "camera": "PINHOLE 64 48 50 50 32 24", "body_from_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 2]]}]})",
       "rig.json: cameras[0].body_from_camera: the fourth row must be [0, 0, 0, 1]"},
      {R"({"cameras": [{"name": "a", "camera": "PINHOLE 64 48 50", "body_from_camera": )" +
           identity + "}]}",
       "rig.json: cameras[0].camera: PINHOLE expects 4 parameters"},
      {R"({"cameras": [{)" + good_camera + R"(, "pose": 1}]})",
       "rig.json: cameras[0].pose: unknown key (expected name, camera, body_from_camera)"},
      {R"({"cameras": [{)" + good_camera +
           R"(}], "lidar": {"format": "velodyne", "body_from_lidar": )" + identity + "}}",
       "rig.json: lidar.format: "},
      {R"({"cameras": [{)" + good_camera + R"(}], "lidar": {"format": "kitti"}})",
       "rig.json: lidar.body_from_lidar: missing"},
      {R"({"cameras": [{)" + good_camera + R"(}], "origin": "body"})",
       "rig.json: origin: unknown key (expected frame, cameras, lidar)"},
  };
  for (const auto& [text, message] : cases) {
    SCOPED_TRACE(text);
    try {
      parse_rig(text, "rig.json", folder_.string());
      ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& error) {
      const std::string what = error.what();
      EXPECT_EQ(what.rfind(message, 0), 0u) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
}

TEST_F(RigFile, AMissingCameraFileNamesTheField) {
  try {
    parse_rig(R"({"cameras": [{"name": "a", "camera": "calib/none.txt",
                  "body_from_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}]})",
              "rig.json", folder_.string());
    FAIL() << "accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()).rfind("rig.json: cameras[0].camera: ", 0), 0u)
        << error.what();
  }
  EXPECT_THROW(read_rig((folder_ / "no_rig.json").string()), std::runtime_error);
}

}  // namespace
}  // namespace omnipoint::io
