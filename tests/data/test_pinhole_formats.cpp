// The pinhole RGB-D readers and the unlabelled-image reader (data/formats/arkitscenes.cpp,
// tartanair.cpp, images.cpp): each test writes a box room seen through the dataset's own
// camera, in its exact native layout, file names and encoding, reads it back through the
// format table, and checks every labelled pixel's point (distance times the sample camera's
// ray) against the room's geometry computed here with the dataset's own pixel convention. A
// half-pixel, unit or z-versus-distance mistake moves points by millimetres to centimetres, far
// more than the encodings' quantisation. Then the bad inputs: one error naming the file and
// the problem.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "data/open_error.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "support/cli_run.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::open_error;
using Vec3 = std::array<double, 3>;

std::string item_error(const Dataset& dataset, int64_t index) {
  try {
    dataset.item({index, 0});
  } catch (const SampleError& error) {
    return error.what();
  }
  return "(no error)";
}

// The room [-2.0, 3.0] x [-1.2, 1.4] x [-2.5, 4.5] m around the camera (x right, y down,
// z forward): no two walls at the same distance.
double room_distance(const Vec3& ray) {
  static const Vec3 low{-2.0, -1.2, -2.5}, high{3.0, 1.4, 4.5};
  double nearest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (ray[a] != 0) nearest = std::min(nearest, (ray[a] > 0 ? high[a] : low[a]) / ray[a]);
  return nearest;
}

// The room seen by a pinhole whose pixel (u, v) looks along (x(u), y(v), 1): true points
// (H, W, 3) and planar depths z (H, W).
struct Truth {
  at::Tensor points;
  at::Tensor z;
};
Truth pinhole_truth(int width, int height, const std::function<double(int)>& x_of,
                    const std::function<double(int)>& y_of) {
  Truth truth{at::zeros({height, width, 3}, at::kDouble), at::zeros({height, width}, at::kDouble)};
  auto points = truth.points.accessor<double, 3>();
  auto z = truth.z.accessor<double, 2>();
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      Vec3 ray{x_of(u), y_of(v), 1.0};
      const double norm = std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + 1.0);
      for (double& r : ray) r /= norm;
      const double d = room_distance(ray);
      for (int a = 0; a < 3; ++a) points[v][u][a] = d * ray[a];
      z[v][u] = d * ray[2];
    }
  return truth;
}

// A colour image with a pattern (its content is not checked, its size is).
void write_rgb(const fs::path& path, int width, int height) {
  fs::create_directories(path.parent_path());
  const at::Tensor u = at::arange(width, at::kFloat).view({1, width}).expand({height, width});
  const at::Tensor v = at::arange(height, at::kFloat).view({height, 1}).expand({height, width});
  io::write_image_png(path.string(),
                      at::stack({u / width, v / height, at::full({height, width}, 0.5)}, -1));
}

// round(value * scale) as a 16-bit grey PNG.
void write_png16(const fs::path& path, const at::Tensor& value, double scale) {
  fs::create_directories(path.parent_path());
  io::write_image_png(path.string(), (value * scale).round().clamp(0, 65535).to(at::kInt));
}

// Every labelled pixel's point within `tolerance` (metres) of the truth; labelled pixels
// exactly those expected.
void expect_points(const Sample& sample, const Truth& truth, const at::Tensor& expected_mask,
                   double tolerance) {
  ASSERT_EQ(sample.distance.size(0), truth.z.size(0));
  ASSERT_EQ(sample.distance.size(1), truth.z.size(1));
  EXPECT_TRUE(sample.metric);
  EXPECT_TRUE(sample.labelled);
  EXPECT_TRUE(at::equal(sample.mask, expected_mask));
  const at::Tensor rays = sample.camera.ray_map(at::kDouble).rays;
  const at::Tensor points = sample.distance.to(at::kDouble).unsqueeze(-1) * rays;
  const at::Tensor error = (points - truth.points).norm(2, -1);
  EXPECT_LE(at::where(sample.mask, error, at::zeros_like(error)).max().item<double>(), tolerance);
}

// The largest point error over the labelled pixels.
double worst_error(const Sample& sample, const Truth& truth) {
  const at::Tensor points =
      sample.distance.to(at::kDouble).unsqueeze(-1) * sample.camera.ray_map(at::kDouble).rays;
  const at::Tensor error = (points - truth.points).norm(2, -1);
  return at::where(sample.mask, error, at::zeros_like(error)).max().item<double>();
}

class PinholeFormats : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
    root_ = test::fresh_process_dir("omnipoint_pinhole_formats");
  }
  void TearDown() override {
    if (!root_.empty()) fs::remove_all(root_);
  }
  fs::path root_;
};

// ARKitScenes' raw layout: 16-bit millimetre z-depth, the .pincam in the devkit's
// integer-centre convention (pixel u's centre at u), file names VIDEO_TIMESTAMP.
TEST_F(PinholeFormats, ArkitScenesMillimetreZDepthAndPincamIntegerCentres) {
  constexpr int width = 64, height = 48;
  const double fx = 52.25, fy = 51.75, cx = 31.5, cy = 23.25;  // as the .pincam writes them
  const Truth truth = pinhole_truth(
      width, height, [&](int u) { return (u - cx) / fx; }, [&](int v) { return (v - cy) / fy; });
  at::Tensor expected = at::ones({height, width}, at::kBool);
  at::Tensor z = truth.z.clone();
  z[5][9] = 0;  // no reading
  expected[5][9] = false;
  const std::string pincam = "64 48 52.25 51.75 31.5 23.25\n";
  const auto write_frame = [&](const std::string& fold, const std::string& video,
                               const std::string& stamp, const std::string& pincam_stamp) {
    const fs::path folder = root_ / fold / video;
    const std::string name = video + "_" + stamp;
    write_rgb(folder / "lowres_wide" / (name + ".png"), width, height);
    write_png16(folder / "lowres_depth" / (name + ".png"), z, 1000);
    fs::create_directories(folder / "lowres_wide_intrinsics");
    std::ofstream(folder / "lowres_wide_intrinsics" / (video + "_" + pincam_stamp + ".pincam"))
        << pincam;
  };
  write_frame("Training", "41069021", "6845.873", "6845.873");
  // The .pincam of this frame carries a timestamp 0.001 later (the devkit's fallback).
  write_frame("Training", "41069021", "6845.890", "6845.891");
  write_frame("Validation", "42445173", "212.003", "212.002");
  // An RGB frame without depth is not an item (not every asset exists per timestamp).
  write_rgb(root_ / "Training/41069021/lowres_wide/41069021_6845.906.png", width, height);

  const auto dataset = open_dataset("arkitscenes", {root_.string()});
  ASSERT_EQ(dataset->size(), 3);
  EXPECT_EQ(dataset->item_name({1, 0}), "Training/41069021/lowres_wide/41069021_6845.890.png");
  const std::vector<std::string> sources = dataset->item_sources({1, 0});
  ASSERT_EQ(sources.size(), 3u);
  EXPECT_EQ(sources[1], (root_ / "Training/41069021/lowres_depth/41069021_6845.890.png").string());
  EXPECT_EQ(sources[2],
            (root_ / "Training/41069021/lowres_wide_intrinsics/41069021_6845.891.pincam").string());
  // A 16-bit millimetre z-depth is at most 0.5 mm / ray.z off along its ray.
  const double tolerance = 0.5e-3 * std::sqrt(1 + std::pow(33.0 / 51.75, 2) * 2) + 1e-5;
  for (int64_t i = 0; i < 3; ++i) {
    const Sample sample = dataset->item({i, 0});
    EXPECT_EQ(sample.camera.model_name(), "PINHOLE");
    EXPECT_DOUBLE_EQ(sample.camera.params()[2], cx + 0.5);  // ours: pixel u spans [u, u + 1)
    expect_points(sample, truth, expected, tolerance);
  }

  // DAC-style corner reading: half a pixel off, millimetres at these distances.
  DatasetLocation corner{root_.string()};
  corner.options["principal_point"] = "corner";
  EXPECT_GT(worst_error(open_dataset("arkitscenes", corner)->item({0, 0}), truth), 5 * tolerance);
  // Named splits and video ids.
  DatasetLocation val{root_.string()};
  val.split = "val";
  ASSERT_EQ(open_dataset("arkitscenes", val)->size(), 1);
  DatasetLocation video{root_.string()};
  video.options["sequence"] = "41069021";
  EXPECT_EQ(open_dataset("arkitscenes", video)->size(), 2);
  DatasetLocation highres{root_.string()};
  highres.options["resolution"] = "highres";
  EXPECT_HAS(open_error("arkitscenes", highres), "highres_depth/<video_id>_<timestamp>.png");

  // A .pincam missing a value; one with a fractional width; then gone.
  const fs::path pincam_path =
      root_ / "Training/41069021/lowres_wide_intrinsics/41069021_6845.873.pincam";
  std::ofstream(pincam_path, std::ios::trunc) << "64 48 52.25 51.75 31.5\n";
  std::string error = item_error(*dataset, 0);
  EXPECT_HAS(error, "Training/41069021/lowres_wide/41069021_6845.873.png");
  EXPECT_HAS(error, pincam_path.string());
  EXPECT_HAS(error, "expected one line of 6 numbers (width height fx fy cx cy)");
  std::ofstream(pincam_path, std::ios::trunc) << "64.5 48 52.25 51.75 31.5 23.25\n";
  EXPECT_HAS(item_error(*dataset, 0), "width \"64.5\" is not a whole number");
  // A .pincam of another size than the image.
  std::ofstream(pincam_path, std::ios::trunc) << "256 192 211 211 127.5 95.5\n";
  EXPECT_HAS(item_error(*dataset, 0), "64x48, but " + pincam_path.string() + " is 256x192");
  std::ofstream(pincam_path, std::ios::trunc) << pincam;
  // A depth PNG of the wrong bit depth, then of the wrong size.
  const fs::path depth_path = root_ / "Training/41069021/lowres_depth/41069021_6845.873.png";
  io::write_image_png(depth_path.string(), at::full({height, width}, 7, at::kByte));
  error = item_error(*dataset, 0);
  EXPECT_HAS(error, depth_path.string());
  EXPECT_HAS(error, "expected a 16-bit grey PNG, got an 8-bit grey one");
  write_png16(depth_path, at::ones({height / 2, width}, at::kDouble), 1000);
  EXPECT_HAS(item_error(*dataset, 0), "64x24, but the image is 64x48");
  // A split list naming a frame that is not there.
  std::ofstream(root_ / "list.txt") << "Validation/42445173/lowres_wide/42445173_212.003.png\n"
                                    << "Validation/42445173/lowres_wide/42445173_999.000.png\n";
  DatasetLocation listed{root_.string()};
  listed.split = (root_ / "list.txt").string();
  error = open_error("arkitscenes", listed);
  EXPECT_HAS(error, "list.txt:2: names");
  EXPECT_HAS(error, "42445173_999.000.png, which does not exist");
  fs::remove(pincam_path);
  EXPECT_HAS(item_error(*dataset, 0), pincam_path.string() + ": cannot open");
}

// TartanAir: float32 metre z-depth in .npy, the fixed 640x480 camera (320, 320, 320, 240)
// read in our corner convention, sky at the sky sphere's ~10000 m.
TEST_F(PinholeFormats, TartanAirNpyMetresFixedCameraAndSky) {
  constexpr int width = 640, height = 480;
  const Truth truth = pinhole_truth(
      width, height, [](int u) { return (u + 0.5 - 320) / 320; },
      [](int v) { return (v + 0.5 - 240) / 320; });
  at::Tensor depth = truth.z.to(at::kFloat).clone();
  at::Tensor expected = at::ones({height, width}, at::kBool);
  depth.slice(0, 0, 20).fill_(10000.0f);  // the sky sphere
  expected.slice(0, 0, 20).fill_(false);
  depth[100][200] = std::numeric_limits<float>::quiet_NaN();
  expected[100][200] = false;
  const auto write_frame = [&](const fs::path& sequence, const std::string& number,
                               const std::string& side) {
    write_rgb(sequence / ("image_" + side) / (number + "_" + side + ".png"), width, height);
    fs::create_directories(sequence / ("depth_" + side));
    io::write_npy((sequence / ("depth_" + side) / (number + "_" + side + "_depth.npy")).string(),
                  depth);
  };
  write_frame(root_ / "abandonedfactory/Easy/P000", "000000", "left");
  write_frame(root_ / "abandonedfactory/Easy/P000", "000000", "right");
  write_frame(root_ / "abandonedfactory/Hard/P011", "000042", "left");
  const auto dataset = open_dataset("tartanair", {root_.string()});
  ASSERT_EQ(dataset->size(), 2);
  EXPECT_EQ(dataset->item_name({1, 0}), "abandonedfactory/Hard/P011/image_left/000042_left.png");
  EXPECT_EQ(dataset->item_sources({1, 0}).back(),
            (root_ / "abandonedfactory/Hard/P011/depth_left/000042_left_depth.npy").string());
  const Sample sample = dataset->item({0, 0});
  EXPECT_EQ(sample.camera.to_spec(), "PINHOLE 640 480 320 320 320 240");
  // float32 metres: the rounding of a float.
  expect_points(sample, truth, expected, 2e-5);
  // The other pixel-centre reading is half a pixel off: millimetres.
  DatasetLocation shifted{root_.string()};
  shifted.options["principal_point"] = "integer-centre";
  EXPECT_GT(worst_error(open_dataset("tartanair", shifted)->item({0, 0}), truth), 3e-3);
  // The sky threshold: below the room's farthest wall everything further is sky.
  DatasetLocation near{root_.string()};
  near.options["sky_depth"] = "4";
  EXPECT_TRUE(
      at::equal(open_dataset("tartanair", near)->item({0, 0}).mask, expected & (depth < 4)));
  near.options["sky_depth"] = "-1";
  EXPECT_HAS(open_error("tartanair", near), "option sky_depth=-1: expected a number in");

  // The right camera, the sequence option, and the zips' extra environment folder.
  DatasetLocation right{root_.string()};
  right.options["camera"] = "right";
  const auto rights = open_dataset("tartanair", right);
  ASSERT_EQ(rights->size(), 1);
  expect_points(rights->item({0, 0}), truth, expected, 2e-5);
  DatasetLocation hard{root_.string()};
  hard.options["sequence"] = "abandonedfactory/Hard";
  EXPECT_EQ(open_dataset("tartanair", hard)->size(), 1);
  const fs::path parent = root_.parent_path() / (root_.filename().string() + "_zip");
  fs::create_directories(parent);
  fs::rename(root_ / "abandonedfactory", parent / "abandonedfactory");
  fs::create_directories(root_);
  fs::rename(parent, root_ / "abandonedfactory");
  const auto nested = open_dataset("tartanair", hard);
  ASSERT_EQ(nested->size(), 1);
  EXPECT_EQ(nested->item_name({0, 0}),
            "abandonedfactory/abandonedfactory/Hard/P011/image_left/000042_left.png");

  // A depth .npy of the wrong dtype, then of the wrong shape; an image of the wrong size.
  const fs::path frame = root_ / "abandonedfactory/abandonedfactory/Hard/P011";
  const fs::path npy = frame / "depth_left/000042_left_depth.npy";
  io::write_npy(npy.string(), depth.to(at::kDouble));
  std::string error = item_error(*nested, 0);
  EXPECT_HAS(error, npy.string() + ": expected a float32 (480, 640) array, got float64 (480, 640)");
  io::write_npy(npy.string(), depth.slice(1, 0, 320));
  EXPECT_HAS(item_error(*nested, 0), "got float32 (480, 320)");
  io::write_npy(npy.string(), depth);
  write_rgb(frame / "image_left/000042_left.png", 320, 240);
  EXPECT_HAS(item_error(*nested, 0), "000042_left.png: 320x240, but the camera is 640x480");
  DatasetLocation other{root_.string()};
  other.options["camera"] = "middle";
  EXPECT_HAS(open_error("tartanair", other), "option camera=middle: expected one of left, right");
}

// Unlabelled images with one camera: items without labels that evaluation refuses.
TEST_F(PinholeFormats, ImagesUnlabelledWithOneCamera) {
  write_rgb(root_ / "frames/b/0002.png", 32, 24);
  write_rgb(root_ / "frames/a/0001.png", 32, 24);
  write_rgb(root_ / "frames/0000.png", 32, 24);
  write_rgb(root_ / "frames/.hidden/0003.png", 32, 24);
  std::ofstream(root_ / "frames/notes.txt") << "not an image\n";
  const std::string spec = "PINHOLE 32 24 30 30 16 12";
  DatasetLocation location{(root_ / "frames").string()};
  EXPECT_HAS(open_error("images", location), "images: option camera is required");
  location.options["camera"] = spec;
  const auto dataset = open_dataset("images", location);
  ASSERT_EQ(dataset->size(), 3);
  EXPECT_EQ(dataset->item_name({0, 0}), "0000.png");
  EXPECT_EQ(dataset->item_name({1, 0}), "a/0001.png");
  EXPECT_EQ(dataset->item_name({2, 0}), "b/0002.png");
  const Sample sample = dataset->item({2, 0});
  EXPECT_FALSE(sample.labelled);
  EXPECT_FALSE(sample.metric);
  EXPECT_FALSE(sample.mask.any().item<bool>());
  EXPECT_EQ(sample.distance.abs().sum().item<double>(), 0.0);
  EXPECT_EQ(sample.camera.to_spec(), spec);
  EXPECT_EQ(sample.image.size(1), 32);
  location.options["sequence"] = "a";
  EXPECT_EQ(open_dataset("images", location)->size(), 1);
  location.options.erase("sequence");

  // Any predict --camera form: a cameras.txt with #ID.
  std::ofstream(root_ / "cameras.txt") << "# COLMAP\n1 PINHOLE 64 48 60 60 32 24\n"
                                       << "7 SIMPLE_PINHOLE 32 24 28 16 12\n";
  DatasetLocation from_file = location;
  from_file.options["camera"] = (root_ / "cameras.txt").string() + "#7";
  EXPECT_EQ(open_dataset("images", from_file)->item({0, 0}).camera.model_name(), "SIMPLE_PINHOLE");
  // A camera of another size: refused at open, naming the option; an image of another size.
  from_file.options["camera"] = (root_ / "cameras.txt").string();
  EXPECT_HAS(open_error("images", from_file), "0000.png: 32x24, but the camera (");
  location.options["camera"] = "PINHOLE 32 24 30";
  EXPECT_HAS(open_error("images", location), "option camera=PINHOLE 32 24 30: ");
  location.options["camera"] = spec;
  write_rgb(root_ / "frames/b/0002.png", 40, 24);
  EXPECT_HAS(item_error(*dataset, 2), "b/0002.png: 40x24, but the camera (" + spec + ") is 32x24");

  // An unlabelled sample round-trips through a sample folder, and eval refuses the set.
  const fs::path samples = root_ / "samples";
  write_sample((samples / "0000").string(), dataset->item({0, 0}));
  const Sample back = read_sample((samples / "0000").string());
  EXPECT_FALSE(back.labelled);
  EXPECT_FALSE(back.mask.any().item<bool>());
  const test::CliRun eval = test::run_omnipoint(
      "eval --baseline constant --data " + samples.string() + " --out " + (root_ / "eval").string(),
      root_ / "cli");
  EXPECT_EQ(eval.status, 1);
  EXPECT_HAS(eval.err, "sample 0000 has no labels (meta.json \"labelled\": false)");
  EXPECT_EQ(std::count(eval.err.begin(), eval.err.end(), '\n'), 1) << eval.err;
  // A labelled sample whose mask is empty is still refused, and an unlabelled one with labels.
  Sample bad = back;
  bad.labelled = true;
  EXPECT_THROW(validate_sample(bad, "x"), std::invalid_argument);
  bad = back;
  bad.mask[0][0] = true;
  bad.distance[0][0] = 1.0f;
  EXPECT_THROW(validate_sample(bad, "x"), std::invalid_argument);
}

TEST_F(PinholeFormats, DataCheckReadsArkitScenes) {
  const fs::path video = root_ / "raw/Training/47333462";
  const Truth truth = pinhole_truth(
      16, 12, [](int u) { return (u - 7.5) / 14; }, [](int v) { return (v - 5.5) / 14; });
  write_rgb(video / "lowres_wide/47333462_101.250.png", 16, 12);
  write_png16(video / "lowres_depth/47333462_101.250.png", truth.z, 1000);
  fs::create_directories(video / "lowres_wide_intrinsics");
  std::ofstream(video / "lowres_wide_intrinsics/47333462_101.250.pincam") << "16 12 14 14 7.5 5.5";
  const test::CliRun run = test::run_omnipoint(
      "data check --format arkitscenes --root " + (root_ / "raw").string(), root_ / "cli");
  ASSERT_EQ(run.status, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(run.out);
  EXPECT_EQ(report["items"], 1);
  EXPECT_EQ(report["camera_models"], nlohmann::json({{"PINHOLE", 1}}));
  EXPECT_EQ(report["metric_items"], 1);
  EXPECT_NEAR(report["distance_range"][1].get<double>(),
              truth.points.norm(2, -1).max().item<double>(), 1e-3);
}

TEST(NativeText, PincamParsesStrictly) {
  const formats::Pincam pincam =
      formats::parse_pincam("256 192 211.5 211.25 127.75 95.5\r\n", "a.pincam");
  EXPECT_EQ(pincam.width, 256);
  EXPECT_EQ(pincam.height, 192);
  EXPECT_DOUBLE_EQ(pincam.fy, 211.25);
  EXPECT_DOUBLE_EQ(pincam.cx, 127.75);
  const auto error_of = [](const std::string& text) {
    try {
      formats::parse_pincam(text, "a.pincam");
    } catch (const std::runtime_error& error) {
      return std::string(error.what());
    }
    return std::string("(no error)");
  };
  EXPECT_HAS(error_of(""), "a.pincam: expected one line of 6 numbers");
  EXPECT_HAS(error_of("256 192 211 211 127\n"), "expected one line of 6 numbers");
  EXPECT_HAS(error_of("256 192 211 211 127 95\n1\n"), "expected one line of 6 numbers");
  EXPECT_HAS(error_of("256 192 211 x 127 95"), "a.pincam:1: fy \"x\" is not a number");
  EXPECT_HAS(error_of("256 0 211 211 127 95"), "height \"0\" is not a whole number");
  EXPECT_HAS(error_of("256 192 -211 211 127 95"), "fx and fy must be positive");
  EXPECT_HAS(error_of("256 192 211 211 nan 95"), "cx \"nan\" is not a number");
}

TEST(PinholeFormatTable, EveryReaderListedWithItsOptions) {
  const std::vector<std::string> names = dataset_formats();
  for (const std::string format : {"arkitscenes", "tartanair", "images"})
    EXPECT_NE(std::find(names.begin(), names.end(), format), names.end()) << format;
  DatasetLocation location{"."};
  location.options["gt_rule"] = "dac";
  EXPECT_HAS(open_error("tartanair", location), "gt_rule");
}

}  // namespace
}  // namespace omnipoint::data
