// The panorama and indoor readers (data/formats/): each test writes a box room seen from an
// off-centre camera in the dataset's exact native layout and encoding, reads it back through
// the format table, and checks every labelled pixel's point (distance times the sample
// camera's ray) against the room's geometry computed here with the dataset's own pixel
// convention (pixel i's centre at i + 0.5 of a W-wide turn, row 0 at the zenith). A half-pixel,
// unit, axis, orientation or z-versus-distance mistake moves points by centimetres, far more
// than the encodings' quantisation. Then the bad inputs: one error naming the file and problem.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/imgcodecs.hpp>
#endif
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "data/open_error.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/io/image.h"
#include "support/cli_run.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::open_error;
using Vec3 = std::array<double, 3>;

#ifdef OMNIPOINT_WITH_OPENCV

constexpr int kWidth = 64, kHeight = 32;

// The room [-2.0, 3.0] x [-1.2, 1.4] x [-2.5, 1.5] m around the camera (our axes: x right,
// y down, z forward): no two walls at the same distance, so a mirrored or turned image fails.
double room_distance(const Vec3& ray) {
  static const Vec3 low{-2.0, -1.2, -2.5}, high{3.0, 1.4, 1.5};
  double nearest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (ray[a] == 0) continue;
    nearest = std::min(nearest, (ray[a] > 0 ? high[a] : low[a]) / ray[a]);
  }
  return nearest;
}

// Pixel (column, row)'s ray of a W x H equirectangular panorama as the datasets store them:
// longitude -pi + (column + 0.5) 2 pi / W measured from +z towards +x, latitude
// pi/2 - (row + 0.5) pi / H, up positive.
Vec3 panorama_ray(int column, int row, int width, int height) {
  const double lon = -M_PI + (column + 0.5) * 2 * M_PI / width;
  const double lat = M_PI / 2 - (row + 0.5) * M_PI / height;
  return {std::cos(lat) * std::sin(lon), -std::sin(lat), std::cos(lat) * std::cos(lon)};
}

// The room's true points (H, W, 3) and distances (H, W) seen through `ray_of`.
struct Truth {
  at::Tensor points;
  at::Tensor distance;
};
Truth room_truth(int width, int height, const std::function<Vec3(int, int)>& ray_of) {
  Truth truth{at::zeros({height, width, 3}, at::kDouble), at::zeros({height, width}, at::kDouble)};
  auto points = truth.points.accessor<double, 3>();
  auto distance = truth.distance.accessor<double, 2>();
  for (int row = 0; row < height; ++row)
    for (int column = 0; column < width; ++column) {
      Vec3 ray = ray_of(column, row);
      const double norm = std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + ray[2] * ray[2]);
      for (double& r : ray) r /= norm;
      const double d = room_distance(ray);
      distance[row][column] = d;
      for (int a = 0; a < 3; ++a) points[row][column][a] = d * ray[a];
    }
  return truth;
}

Truth panorama_truth(int width = kWidth, int height = kHeight) {
  return room_truth(width, height,
                    [&](int column, int row) { return panorama_ray(column, row, width, height); });
}

void write_image(const fs::path& path, const cv::Mat& image) {
  fs::create_directories(path.parent_path());
  ASSERT_TRUE(cv::imwrite(path.string(), image)) << path;
}

// A colour image with a pattern (its content is not checked, its size is).
void write_rgb(const fs::path& path, int width = kWidth, int height = kHeight) {
  cv::Mat image(height, width, CV_8UC3);
  for (int row = 0; row < height; ++row)
    for (int column = 0; column < width; ++column)
      image.at<cv::Vec3b>(row, column) =
          cv::Vec3b(static_cast<uint8_t>(4 * column), static_cast<uint8_t>(8 * row), 128);
  write_image(path, image);
}

// round(value * scale) as a 16-bit grey PNG.
cv::Mat encode16(const at::Tensor& value, double scale) {
  const at::Tensor code = (value * scale).round().clamp(0, 65535).to(at::kInt).contiguous();
  cv::Mat image(static_cast<int>(value.size(0)), static_cast<int>(value.size(1)), CV_16UC1);
  auto codes = code.accessor<int, 2>();
  for (int row = 0; row < image.rows; ++row)
    for (int column = 0; column < image.cols; ++column)
      image.at<uint16_t>(row, column) = static_cast<uint16_t>(codes[row][column]);
  return image;
}

// Every labelled pixel's point within `tolerance` (metres) of the truth; `labelled` pixels
// exactly those expected.
void expect_points(const Sample& sample, const Truth& truth, const at::Tensor& expected_mask,
                   double tolerance) {
  ASSERT_EQ(sample.distance.size(0), truth.distance.size(0));
  ASSERT_EQ(sample.distance.size(1), truth.distance.size(1));
  EXPECT_TRUE(sample.metric);
  EXPECT_TRUE(at::equal(sample.mask, expected_mask));
  const at::Tensor rays = sample.camera.ray_map(at::kDouble).rays;
  const at::Tensor points = sample.distance.to(at::kDouble).unsqueeze(-1) * rays;
  const at::Tensor error = (points - truth.points).norm(2, -1);
  const double worst = at::where(sample.mask, error, at::zeros_like(error)).max().item<double>();
  EXPECT_LE(worst, tolerance);
  EXPECT_TRUE(at::equal(sample.distance == 0, ~sample.mask));
}

std::string item_error(const Dataset& dataset, int64_t index) {
  try {
    dataset.item({index, 0});
  } catch (const SampleError& error) {
    return error.what();
  }
  return "(no error)";
}

class PanoramaFormats : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
    root_ = test::fresh_process_dir("omnipoint_panorama_formats");
  }
  void TearDown() override {
    if (!root_.empty()) fs::remove_all(root_);
  }
  fs::path root_;
};

const std::string kStanfordName = "camera_029bb1440fca47e2886a88559bbf8d00_hallway_1_frame_";

TEST_F(PanoramaFormats, Stanford2d3dDistanceIn512thsOfAMetreWith65535Missing) {
  const Truth truth = panorama_truth();
  // The top rows unobserved (65535), one pixel with no distance (0).
  at::Tensor stored = truth.distance.clone();
  at::Tensor expected = at::ones({kHeight, kWidth}, at::kBool);
  cv::Mat depth = encode16(stored, 512);
  for (int column = 0; column < kWidth; ++column) depth.at<uint16_t>(0, column) = 65535;
  depth.at<uint16_t>(10, 20) = 0;
  expected[0] = false;
  expected[10][20] = false;
  for (const std::string area : {"area_1", "area_5a"}) {
    write_rgb(root_ / area / "pano/rgb" / (kStanfordName + "equirectangular_domain_rgb.png"));
    write_image(root_ / area / "pano/depth" / (kStanfordName + "equirectangular_domain_depth.png"),
                depth);
  }
  const auto dataset = open_dataset("stanford2d3d", {root_.string()});
  ASSERT_EQ(dataset->size(), 2);
  EXPECT_EQ(dataset->item_name({1, 0}),
            "area_5a/pano/rgb/" + kStanfordName + "equirectangular_domain_rgb.png");
  const std::vector<std::string> sources = dataset->item_sources({1, 0});
  ASSERT_EQ(sources.size(), 2u);
  EXPECT_EQ(sources[1],
            (root_ / "area_5a/pano/depth" / (kStanfordName + "equirectangular_domain_depth.png"))
                .string());
  const Sample sample = dataset->item({1, 0});
  EXPECT_EQ(sample.camera.model_name(), "EQUIRECTANGULAR");
  expect_points(sample, truth, expected, 0.5 / 512 + 1e-5);

  // Option sequence: areas.
  DatasetLocation area5{root_.string()};
  area5.options["sequence"] = "area_5a";
  EXPECT_EQ(open_dataset("stanford2d3d", area5)->size(), 1);

  // DA²'s list ("area/pano/rgb/NAME area/pano/depth/NAME") and UniFuse's (its own rgb_ folder):
  // both name the panorama by area and file name.
  std::ofstream(root_ / "lists.txt")
      << "# fold 1\narea_5a/rgb_/" << kStanfordName << "equirectangular_domain_rgb.png "
      << "area_5a/depth/" << kStanfordName << "equirectangular_domain_depth.png\n";
  DatasetLocation listed{root_.string()};
  listed.split = (root_ / "lists.txt").string();
  const auto fold = open_dataset("stanford2d3d", listed);
  ASSERT_EQ(fold->size(), 1);
  EXPECT_EQ(fold->item_name({0, 0}), dataset->item_name({1, 0}));
  // A list naming a panorama that is not there: the list, its line and the missing file.
  std::ofstream(root_ / "lists.txt", std::ios::app)
      << "area_6/pano/rgb/camera_x_office_1_frame_equirectangular_domain_rgb.png\n";
  const std::string missing = open_error("stanford2d3d", listed);
  EXPECT_HAS(missing, "lists.txt:3");
  EXPECT_HAS(missing, "camera_x_office_1_frame_equirectangular_domain_rgb.png");
  EXPECT_HAS(missing, "does not exist");

  // A depth PNG of the wrong bit depth, then of the wrong size: the item and the file named.
  const fs::path depth_path =
      root_ / "area_1/pano/depth" / (kStanfordName + "equirectangular_domain_depth.png");
  write_image(depth_path, cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(7)));
  std::string error = item_error(*dataset, 0);
  EXPECT_HAS(error, "area_1/pano/rgb/");
  EXPECT_HAS(error, depth_path.string());
  EXPECT_HAS(error, "expected a 16-bit grey PNG, got an 8-bit grey one");
  write_image(depth_path, cv::Mat(kHeight / 2, kWidth, CV_16UC1, cv::Scalar(700)));
  error = item_error(*dataset, 0);
  EXPECT_HAS(error, "64x16, but the image is 64x32");
  // Not a PNG at all.
  std::ofstream(depth_path, std::ios::trunc) << "not a png";
  EXPECT_HAS(item_error(*dataset, 0), depth_path.string() + ": not a PNG file");

  EXPECT_HAS(open_error("stanford2d3d", {(root_ / "nothing").string()}), "not a folder");
  fs::create_directories(root_ / "empty");
  EXPECT_HAS(open_error("stanford2d3d", {(root_ / "empty").string()}), "holds no items");
}

TEST_F(PanoramaFormats, Matterport360DistanceIn4000thsOfAMetreWith0Missing) {
  const Truth truth = panorama_truth();
  cv::Mat depth = encode16(truth.distance, 4000);
  at::Tensor expected = at::ones({kHeight, kWidth}, at::kBool);
  for (int column = 0; column < kWidth; ++column) depth.at<uint16_t>(kHeight - 1, column) = 0;
  expected[kHeight - 1] = false;
  const std::string id = "0b22fa63d0f54a529c525afbf2e8bb25";
  write_rgb(root_ / "17DRP5sb8fy/pano_skybox_color" / (id + ".jpg"));
  write_image(root_ / "17DRP5sb8fy/pano_depth" / (id + ".png"), depth);
  const auto dataset = open_dataset("matterport360", {root_.string()});
  ASSERT_EQ(dataset->size(), 1);
  EXPECT_EQ(dataset->item_name({0, 0}), "17DRP5sb8fy/pano_skybox_color/" + id + ".jpg");
  expect_points(dataset->item({0, 0}), truth, expected, 0.5 / 4000 + 1e-5);

  // UniFuse's list line; the colour stitched from the 18 views is the other option.
  std::ofstream(root_ / "test.txt")
      << "17DRP5sb8fy/pano_skybox_color/" << id << ".jpg 17DRP5sb8fy/pano_depth/" << id << ".png\n";
  DatasetLocation listed{root_.string()};
  listed.split = (root_ / "test.txt").string();
  EXPECT_EQ(open_dataset("matterport360", listed)->size(), 1);
  DatasetLocation stitched{root_.string()};
  stitched.options["color"] = "stitched";
  EXPECT_HAS(open_error("matterport360", stitched), "*/pano_color/*.jpg");
  stitched.options["color"] = "cube";
  EXPECT_HAS(open_error("matterport360", stitched), "option color=cube: expected one of");

  // A 3-channel depth PNG.
  write_image(root_ / "17DRP5sb8fy/pano_depth" / (id + ".png"),
              cv::Mat(kHeight, kWidth, CV_16UC3, cv::Scalar(1, 2, 3)));
  EXPECT_HAS(item_error(*dataset, 0), "expected a 16-bit grey PNG, got a 16-bit RGB one");
}

TEST_F(PanoramaFormats, Pano3dFloatMetresWithInfInvalid) {
  if (!cv::haveImageWriter(".exr")) GTEST_SKIP() << "this OpenCV writes no OpenEXR";
  const Truth truth = panorama_truth();
  const at::Tensor stored = truth.distance.to(at::kFloat).contiguous();
  cv::Mat depth(kHeight, kWidth, CV_32FC1);
  std::memcpy(depth.data, stored.data_ptr<float>(), sizeof(float) * kWidth * kHeight);
  at::Tensor expected = at::ones({kHeight, kWidth}, at::kBool);
  for (int column = 0; column < kWidth; ++column)
    depth.at<float>(0, column) = std::numeric_limits<float>::infinity();
  depth.at<float>(5, 5) = std::numeric_limits<float>::quiet_NaN();
  expected[0] = false;
  expected[5][5] = false;
  write_rgb(root_ / "2t7WUuJeko7/0_spherical_1_emission_center_0.png");
  write_image(root_ / "2t7WUuJeko7/0_spherical_1_depth_center_0.exr", depth);
  const auto dataset = open_dataset("pano3d", {root_.string()});
  ASSERT_EQ(dataset->size(), 1);
  // float32 metres: the rounding of a float.
  expect_points(dataset->item({0, 0}), truth, expected, 1e-5);
  EXPECT_EQ(dataset->item_sources({0, 0}).back(),
            (root_ / "2t7WUuJeko7/0_spherical_1_depth_center_0.exr").string());

  // A 3-channel EXR.
  write_image(root_ / "2t7WUuJeko7/0_spherical_1_depth_center_0.exr",
              cv::Mat(kHeight, kWidth, CV_32FC3, cv::Scalar(1, 1, 1)));
  EXPECT_HAS(item_error(*dataset, 0), "expected a single-channel float EXR, got 3 channels");
}

TEST_F(PanoramaFormats, PanoSuncg8BitTenMetresOver255) {
  const Truth truth = panorama_truth();
  // UniFuse's decode: value * 10 / 255, the mean of three equal channels; 0 no geometry.
  const at::Tensor code = (truth.distance * 25.5).round().clamp(0, 255).to(at::kInt);
  cv::Mat depth(kHeight, kWidth, CV_8UC3);
  auto codes = code.accessor<int, 2>();
  at::Tensor expected = at::ones({kHeight, kWidth}, at::kBool);
  for (int row = 0; row < kHeight; ++row)
    for (int column = 0; column < kWidth; ++column) {
      const auto value = static_cast<uint8_t>(row == 3 && column < 8 ? 0 : codes[row][column]);
      depth.at<cv::Vec3b>(row, column) = cv::Vec3b(value, value, value);
    }
  expected.index_put_({3, at::indexing::Slice(0, 8)}, false);
  const std::string folder = "rotated/3e2ce3b4d1e0b9f2a4c1f7d5c8e9a0b1/5.txt";
  write_rgb(root_ / folder / "12_color.png");
  write_image(root_ / folder / "12_depth.png", depth);
  const auto dataset = open_dataset("panosuncg", {root_.string()});
  ASSERT_EQ(dataset->size(), 1);
  EXPECT_EQ(dataset->item_name({0, 0}), "3e2ce3b4d1e0b9f2a4c1f7d5c8e9a0b1/5.txt/12_color.png");
  expect_points(dataset->item({0, 0}), truth, expected, 0.5 * 10 / 255 + 1e-5);

  // The root may be rotated/ itself; list lines may start with "rotated/".
  EXPECT_EQ(open_dataset("panosuncg", {(root_ / "rotated").string()})->size(), 1);
  std::ofstream(root_ / "panosuncg_test.txt")
      << folder << "/12_color.png " << folder << "/12_depth.png\n";
  DatasetLocation listed{root_.string()};
  listed.split = (root_ / "panosuncg_test.txt").string();
  EXPECT_EQ(open_dataset("panosuncg", listed)->size(), 1);
  // Option depth_scale (DA²'s 1/20): every distance scaled by its ratio to 10/255.
  DatasetLocation scaled{root_.string()};
  scaled.options["depth_scale"] = "0.05";
  const Sample twentieths = open_dataset("panosuncg", scaled)->item({0, 0});
  const Sample metres = dataset->item({0, 0});
  EXPECT_TRUE(at::allclose(twentieths.distance, metres.distance * (0.05 * 25.5), 1e-5, 1e-6));
  scaled.options["depth_scale"] = "-1";
  EXPECT_HAS(open_error("panosuncg", scaled), "option depth_scale=-1: expected a number in");

  // A 16-bit depth PNG.
  write_image(root_ / folder / "12_depth.png", cv::Mat(kHeight, kWidth, CV_16UC1, cv::Scalar(9)));
  EXPECT_HAS(item_error(*dataset, 0), "expected an 8-bit grey PNG, got a 16-bit grey one");
}

TEST_F(PanoramaFormats, Structured3dPanoramaMillimetresAndNamedSplits) {
  const Truth truth = panorama_truth();
  cv::Mat depth = encode16(truth.distance, 1000);
  depth.at<uint16_t>(7, 7) = 0;
  at::Tensor expected = at::ones({kHeight, kWidth}, at::kBool);
  expected[7][7] = false;
  for (const std::string scene : {"scene_00012", "scene_03001", "scene_03300"}) {
    const fs::path folder = root_ / scene / "2D_rendering/485142/panorama/full";
    write_rgb(folder / "rgb_rawlight.png");
    write_rgb(folder / "rgb_warmlight.png");
    write_image(folder / "depth.png", depth);
  }
  const auto dataset = open_dataset("structured3d", {root_.string()});
  ASSERT_EQ(dataset->size(), 3);
  EXPECT_EQ(dataset->item_name({0, 0}),
            "scene_00012/2D_rendering/485142/panorama/full/rgb_rawlight.png");
  expect_points(dataset->item({0, 0}), truth, expected, 0.5e-3 + 1e-5);
  for (const std::string split : {"train", "val", "test"}) {
    DatasetLocation location{root_.string()};
    location.split = split;
    const auto part = open_dataset("structured3d", location);
    ASSERT_EQ(part->size(), 1) << split;
    const std::string scene = split == "train" ? "scene_00012"
                              : split == "val" ? "scene_03001"
                                               : "scene_03300";
    EXPECT_EQ(part->item_name({0, 0}).substr(0, 11), scene);
  }
  DatasetLocation warm{root_.string()};
  warm.options["lighting"] = "warm";
  warm.options["sequence"] = "scene_03001";
  const auto warm_items = open_dataset("structured3d", warm);
  ASSERT_EQ(warm_items->size(), 1);
  EXPECT_EQ(warm_items->item_name({0, 0}),
            "scene_03001/2D_rendering/485142/panorama/full/rgb_warmlight.png");
  DatasetLocation simple{root_.string()};
  simple.options["furniture"] = "simple";
  EXPECT_HAS(open_error("structured3d", simple), "panorama/simple/rgb_rawlight.png");
}

TEST_F(PanoramaFormats, Structured3dPerspectiveZDepthAndHalfFieldsOfView) {
  // camera_pose.txt's xfov, yfov: half-angles to the image edges, principal point the centre.
  constexpr int width = 48, height = 36;
  const double half_fov_x = 0.6, half_fov_y = 0.48;
  const double fx = (width / 2.0) / std::tan(half_fov_x),
               fy = (height / 2.0) / std::tan(half_fov_y);
  const Truth truth = room_truth(width, height, [&](int column, int row) {
    return Vec3{(column + 0.5 - width / 2.0) / fx, (row + 0.5 - height / 2.0) / fy, 1.0};
  });
  // The depth PNG holds the z-buffer in mm.
  const at::Tensor z = truth.points.select(-1, 2);
  const fs::path folder = root_ / "scene_00007/2D_rendering/2204/perspective/full/0";
  write_rgb(folder / "rgb_rawlight.png", width, height);
  write_image(folder / "depth.png", encode16(z, 1000));
  std::ofstream(folder / "camera_pose.txt")
      << "-1083.7 2450.2 1400.0 0.98 -0.17 0.0 0.0 0.0 1.0 0.6 0.48 1\n";
  DatasetLocation location{root_.string()};
  location.options["view"] = "perspective";
  const auto dataset = open_dataset("structured3d", location);
  ASSERT_EQ(dataset->size(), 1);
  const Sample sample = dataset->item({0, 0});
  EXPECT_EQ(sample.camera.model_name(), "PINHOLE");
  // A z-depth quantised to 0.5 mm is at most 0.5 mm / ray.z off along its ray.
  expect_points(sample, truth, at::ones({height, width}, at::kBool), 0.5e-3 / std::cos(0.8) + 1e-5);

  // The other reading (the file holding distance) differs off the centre.
  location.options["perspective_depth"] = "distance";
  const Sample as_distance = open_dataset("structured3d", location)->item({0, 0});
  EXPECT_GT((as_distance.distance - sample.distance).abs().max().item<double>(), 0.05);
  location.options.erase("perspective_depth");

  // A pose missing its last field; half-angles out of range.
  std::ofstream(folder / "camera_pose.txt", std::ios::trunc)
      << "-1083.7 2450.2 1400.0 0.98 -0.17 0.0 0.0 0.0 1.0 0.6 0.48\n";
  std::string error = item_error(*dataset, 0);
  EXPECT_HAS(error, (folder / "camera_pose.txt").string());
  EXPECT_HAS(error, "expected one line of 12 numbers");
  std::ofstream(folder / "camera_pose.txt", std::ios::trunc) << "0 0 0 0 1 0 0 0 1 1.7 0.48 1\n";
  EXPECT_HAS(item_error(*dataset, 0), "half-angles in (0, pi/2)");
  location.options["lighting"] = "warm";
  EXPECT_HAS(open_error("structured3d", location), "raw light only");
}

TEST_F(PanoramaFormats, DataFormatsAndCheckCommands) {
  const auto run = [&](const std::string& args) {
    return test::run_omnipoint(args, root_ / "cli");
  };
  const test::CliRun formats = run("data formats");
  ASSERT_EQ(formats.status, 0) << formats.err;
  EXPECT_HAS(formats.out, "stanford2d3d\n  Stanford 2D-3D-Semantics panoramas");
  EXPECT_HAS(formats.out, "  option depth_scale: metres per depth unit");
  EXPECT_HAS(formats.out, "  splits: train val test\n");

  const Truth truth = panorama_truth();
  cv::Mat depth = encode16(truth.distance, 512);
  for (int column = 0; column < kWidth; ++column) depth.at<uint16_t>(0, column) = 65535;
  const fs::path data = root_ / "2d3ds";
  for (const std::string room : {"hallway_1", "office_2"}) {
    const std::string name = "camera_0a_" + room + "_frame_equirectangular_domain_";
    write_rgb(data / "area_3/pano/rgb" / (name + "rgb.png"));
    write_image(data / "area_3/pano/depth" / (name + "depth.png"), depth);
  }
  const fs::path bad_depth =
      data / "area_3/pano/depth/camera_0a_office_2_frame_equirectangular_domain_depth.png";
  write_image(bad_depth, cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(1)));
  const std::string check = "data check --format stanford2d3d --root " + data.string() +
                            " --sheet " + (root_ / "sheet.png").string();
  test::CliRun result = run(check);
  EXPECT_EQ(result.status, 1);
  // The report first, then one error line.
  const nlohmann::json report = nlohmann::json::parse(result.out);
  EXPECT_EQ(report["items"], 2);
  EXPECT_EQ(report["read"], 2);
  ASSERT_EQ(report["failed"].size(), 1u);
  EXPECT_HAS(report["failed"][0].get<std::string>(), "expected a 16-bit grey PNG");
  EXPECT_EQ(report["camera_models"], nlohmann::json({{"EQUIRECTANGULAR", 1}}));
  EXPECT_EQ(report["metric_items"], 1);
  // One row of 32 missing: 31/32 labelled.
  EXPECT_NEAR(report["label_density"]["mean"].get<double>(), 31.0 / 32, 1e-9);
  const at::Tensor labelled = truth.distance.slice(0, 1);
  EXPECT_NEAR(report["distance_range"][0].get<double>(), labelled.min().item<double>(), 1e-3);
  EXPECT_NEAR(report["distance_range"][1].get<double>(), labelled.max().item<double>(), 1e-3);
  EXPECT_EQ(result.err,
            "omnipoint: error: data check: 0 missing files, 1 of 2 items do not read (first: " +
                report["failed"][0].get<std::string>() + ")\n");
  // The sheet: the readable item's row, image | distance, 160 pixels high.
  const at::Tensor sheet = io::read_image((root_ / "sheet.png").string());
  EXPECT_EQ(sheet.size(0), 160);
  EXPECT_EQ(sheet.size(1), 2 * 320);

  write_image(bad_depth, depth);
  result = run(check + " --limit 1");
  EXPECT_EQ(result.status, 0) << result.err;
  EXPECT_EQ(nlohmann::json::parse(result.out)["read"], 1);
  fs::remove(bad_depth);
  result = run(check);
  EXPECT_EQ(result.status, 1);
  EXPECT_EQ(nlohmann::json::parse(result.out)["missing_files"],
            nlohmann::json::array({bad_depth.string()}));
  EXPECT_HAS(result.err, "1 missing files");

  result = run("data check --format nope --root " + data.string());
  EXPECT_EQ(result.status, 1);
  EXPECT_HAS(result.err, "nope");
  EXPECT_EQ(result.out, "");
  result = run("data check --format stanford2d3d --root " + data.string() + " --option bad");
  EXPECT_HAS(result.err, "--option bad: expected NAME=VALUE");
}

#endif  // OMNIPOINT_WITH_OPENCV

TEST(NativeText, SplitListsAndPosesParseStrictly) {
  const auto lines = formats::parse_split_list("# c\n\na b 512.0\r\n  c\n", "list.txt");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].number, 3);
  EXPECT_EQ(lines[0].fields, (std::vector<std::string>{"a", "b", "512.0"}));
  EXPECT_EQ(lines[1].fields, (std::vector<std::string>{"c"}));
  const auto error_of = [](const std::string& text) {
    try {
      formats::parse_split_list(text, "list.txt");
    } catch (const std::runtime_error& error) {
      return std::string(error.what());
    }
    return std::string("(no error)");
  };
  EXPECT_HAS(error_of("a\na b c d\n"), "list.txt:2: expected 1 to 3 fields");
  EXPECT_HAS(error_of("/abs/a.png\n"), "list.txt:1: \"/abs/a.png\" is not relative");
  EXPECT_HAS(error_of("x/../../a.png\n"), "climbs out of the root");
  EXPECT_HAS(error_of(std::string("a\0b\n", 4)), "NUL byte");

  const auto pose =
      formats::parse_structured3d_pose("1 2 3 0 1 0 0 0 1 0.5 0.4 1\n", "camera_pose.txt");
  EXPECT_EQ(pose.eye, (std::array<double, 3>{1, 2, 3}));
  EXPECT_DOUBLE_EQ(pose.half_fov_y, 0.4);
  EXPECT_THROW(formats::parse_structured3d_pose("1 2 3 0 1 0 0 0 1 0.5 x 1", "p"),
               std::runtime_error);
  EXPECT_THROW(formats::parse_structured3d_pose("", "p"), std::runtime_error);
}

TEST(PanoramaFormatTable, EveryReaderListedWithItsOptions) {
  const std::vector<std::string> names = dataset_formats();
  for (const std::string format :
       {"stanford2d3d", "matterport360", "pano3d", "panosuncg", "structured3d"})
    EXPECT_NE(std::find(names.begin(), names.end(), format), names.end()) << format;
  DatasetLocation location{"."};
  location.options["camera"] = "image_02";
  EXPECT_HAS(open_error("stanford2d3d", location), "camera");
}

}  // namespace
}  // namespace omnipoint::data
