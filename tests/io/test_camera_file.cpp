// Cameras from files (io::read_camera): cameras.txt with ids, single-line and JSON files, and
// every error path naming the file and what it expects.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "omnipoint/io/camera_file.h"
#include "support/expect_error.h"

namespace omnipoint::io {
namespace {
namespace fs = std::filesystem;

using test::expect_error;

void expect_bad_spec(const std::string& spec, const std::vector<std::string>& parts) {
  expect_error<std::invalid_argument>([&] { read_camera(spec); }, parts);
}

class SpecFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("omnipoint_spec_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& content) {
    auto path = (dir_ / name).string();
    std::ofstream(path) << content;
    return path;
  }
  fs::path dir_;
};

TEST(CameraFile, SpecStringsPassThrough) {
  EXPECT_EQ(read_camera("PINHOLE 64 48 50 50 32 24"),
            camera::parse_camera("PINHOLE 64 48 50 50 32 24"));
}

TEST(CameraFile, MissingFileSaysWhatWasExpected) {
  expect_error<std::runtime_error>(
      [] { read_camera("/no/such/cameras.txt"); },
      {"'/no/such/cameras.txt'", "not a camera line", "existing file"});
}

TEST_F(SpecFiles, CamerasTxtFirstAndById) {
  const auto path = write("cameras.txt",
                          "# Camera list with one line of data per camera:\n"
                          "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                          "# Number of cameras: 2\n"
                          "1 PINHOLE 640 480 500 500 320 240\n"
                          "\n"
                          "7 SIMPLE_RADIAL 320 240 250 160 120 -0.05\n");
  EXPECT_EQ(read_camera(path).model_name(), "PINHOLE");
  EXPECT_EQ(read_camera(path + "#7").model_name(), "SIMPLE_RADIAL");
  EXPECT_EQ(read_camera(path + ":7").model_name(), "SIMPLE_RADIAL");
  EXPECT_EQ(read_camera(path + ":1").model_name(), "PINHOLE");
  expect_bad_spec(path + "#3", {path, "no camera with id 3", "ids: 1 7"});
  expect_bad_spec(path + "#x", {"camera id must be an integer"});
}

TEST_F(SpecFiles, SingleLineAndJsonFiles) {
  EXPECT_EQ(read_camera(write("cam.txt", "FOV 640 480 300 300 320 240 0.9\n")).model_name(), "FOV");
  const auto json =
      write("cam.json", R"({"model": "EQUIRECTANGULAR", "width": 64, "height": 32, "params": []})");
  EXPECT_EQ(read_camera(json).model_name(), "EQUIRECTANGULAR");
  expect_bad_spec(json + "#2", {"JSON camera file holds one camera"});
}

TEST_F(SpecFiles, BadFiles) {
  expect_bad_spec(write("empty.txt", "# nothing\n"), {"contains no camera"});
  expect_bad_spec(write("junk.txt", "hello world\n"), {"not a camera line"});
  expect_bad_spec(write("bad.json", "{\"model\": \n"), {"bad.json", "not valid JSON"});
  expect_bad_spec(write("badcount.txt", "1 PINHOLE 640 480 500 500\n"),
                  {"PINHOLE", "expects 4 parameters"});
}

}  // namespace
}  // namespace omnipoint::io
