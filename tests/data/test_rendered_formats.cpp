// The readers of the rendered training sets (data/formats/hypersim.cpp, vkitti2.cpp): each test
// writes a box scene in the dataset's exact native layout and encoding (Hypersim's float16
// HDF5 images and metadata CSVs, Virtual KITTI 2's centimetre z-buffer PNGs and intrinsic.txt),
// with each pixel's ray computed here by the dataset's own rule (Hypersim's M_cam_from_uv on
// notebook 01's NDC grid, VKITTI 2's K with pixel i's centre at i), reads it back through the
// format table, and checks every labelled pixel's point (distance times the sample camera's ray)
// against the scene within the encoding's quantisation: a half-pixel, unit, axis or
// z-versus-distance mistake moves points by centimetres or more. Then the bad inputs.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#ifdef OMNIPOINT_WITH_HDF5
#include <hdf5.h>
#endif
#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/imgcodecs.hpp>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "data/driving_files.h"
#include "data/hdf5_files.h"
#include "data/open_error.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/io/image.h"
#include "support/expect_error.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::open_error;
using Vec3 = std::array<double, 3>;
using test::write_text;

#if defined(OMNIPOINT_WITH_HDF5) || defined(OMNIPOINT_WITH_OPENCV)

// The nearest of the planes x = low/high[0], y = low/high[1], z = low/high[2] that `ray` (our
// axes: x right, y down, z forward) meets, as the distance along the unit ray, and the axis
// (0, 1, 2) and side (0 low, 1 high) of that plane.
struct Hit {
  double distance = std::numeric_limits<double>::infinity();
  int axis = -1, side = -1;
};
Hit box_hit(const Vec3& ray, const Vec3& low, const Vec3& high) {
  const double norm = std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + ray[2] * ray[2]);
  Hit hit;
  for (int a = 0; a < 3; ++a) {
    if (ray[a] == 0) continue;
    const double t = (ray[a] > 0 ? high[a] : low[a]) / (ray[a] / norm);
    if (t < hit.distance) hit = {t, a, ray[a] > 0 ? 1 : 0};
  }
  return hit;
}

// Every labelled pixel's point within `tolerance` (H, W) metres of `points` (H, W, 3); the mask
// exactly `expected_mask`.
void expect_points(const Sample& sample, const at::Tensor& points, const at::Tensor& tolerance,
                   const at::Tensor& expected_mask) {
  ASSERT_EQ(sample.distance.size(0), points.size(0));
  ASSERT_EQ(sample.distance.size(1), points.size(1));
  EXPECT_TRUE(sample.metric);
  EXPECT_TRUE(at::equal(sample.mask, expected_mask));
  const at::Tensor read =
      sample.distance.to(at::kDouble).unsqueeze(-1) * sample.camera.ray_map(at::kDouble).rays;
  const at::Tensor excess = (read - points).norm(2, -1) - tolerance;
  EXPECT_LE(at::where(sample.mask, excess, at::zeros_like(excess)).max().item<double>(), 0.0);
  EXPECT_TRUE(at::equal(sample.distance == 0, ~sample.mask));
}

class RenderedFormats : public ::testing::Test {
 protected:
  void SetUp() override { root_ = test::fresh_process_dir("omnipoint_rendered_formats"); }
  void TearDown() override { fs::remove_all(root_); }
  fs::path root_;
};

#endif  // OMNIPOINT_WITH_HDF5 || OMNIPOINT_WITH_OPENCV

// ---- Hypersim ----

#ifdef OMNIPOINT_WITH_HDF5

using test::float16_type;
using test::write_float16;
using test::write_hdf5;
using test::write_int16;

constexpr int kHypersimWidth = 64, kHypersimHeight = 48;

// Rows of the dataset's metadata_camera_parameters.csv (contrib/mikeroberts3000, M_cam_from_uv
// as published): the standard camera, a principal-point shift, a shift with a 22-degree
// vertical tilt, and a tilt about two axes (with skew).
const std::map<std::string, std::array<double, 9>> kCamFromUv = {
    {"ai_001_001", {0.5773502886169104, 0, 0, 0, 0.4330127164626828, 0, 0, 0, -1}},
    {"ai_026_007",
     {0.5773759486498881, 0, -0.011547518714890601, 0, 0.4330319614874161, 0, 0, 0,
      -1.0000444443776726}},
    {"ai_038_009",
     {0.6088745353317421, 0, -0.04870996173778685, 0, 0.42281668362380326, -0.11275110051191127, 0,
      -0.17251279495462457, -1.0546015951381162}},
    {"ai_019_007",
     {0.5816325918420933, 0, 0, 0, 0.4521482462309275, 0, 0.16414578812081862,
      -0.031774812884525834, -1.0334879501698204}}};

// The CSV as published (a subset of its columns, in its order; an empty column as it has).
std::string camera_csv(const std::vector<std::string>& scenes, const std::string& drop = "") {
  std::vector<std::string> columns = {"scene_name",
                                      "settings_output_img_height",
                                      "settings_output_img_width",
                                      "settings_units_info_meters_scale",
                                      "use_camera_physical",
                                      "camera_physical_anisotropy"};
  for (int i = 0; i < 9; ++i)
    columns.push_back("M_cam_from_uv_" + std::to_string(i / 3) + std::to_string(i % 3));
  columns.emplace_back("M_proj_00");
  std::string text;
  for (const std::string& column : columns)
    if (column != drop) text += (text.empty() ? "" : ",") + column;
  text += "\n";
  for (const std::string& scene : scenes) {
    std::vector<std::string> fields = {scene,
                                       std::to_string(kHypersimHeight) + ".0",
                                       std::to_string(kHypersimWidth) + ".0",
                                       "0.02539999969303608",
                                       "False",
                                       ""};
    for (double value : kCamFromUv.at(scene)) {
      char number[40];
      std::snprintf(number, sizeof number, "%.17g", value);
      fields.emplace_back(number);
    }
    fields.emplace_back("1.7320507492870254");
    std::string row;
    for (std::size_t i = 0; i < fields.size(); ++i)
      if (columns[i] != drop) row += (i == 0 ? "" : ",") + fields[i];
    text += row + "\n";
  }
  return text;
}

// Hypersim's camera-space ray (x right, y up, z backwards) of pixel (column, row), as notebook
// 01 casts them: u, v on the grid linspace(-1 + du/2, 1 - du/2), v's rows reversed.
Vec3 hypersim_ray(const std::array<double, 9>& m, int column, int row) {
  const double u = -1 + (column + 0.5) * 2.0 / kHypersimWidth;
  const double v = 1 - (row + 0.5) * 2.0 / kHypersimHeight;
  return {m[0] * u + m[1] * v + m[2], m[3] * u + m[4] * v + m[5], m[6] * u + m[7] * v + m[8]};
}

// The room [-2, 3] x [-1.2, 1.4] x [-1, 4.5] m (our axes) seen through a scene's rays: the
// points (H, W, 3) in our axes and the distances (H, W).
struct HypersimTruth {
  at::Tensor points, distance;
};
HypersimTruth hypersim_truth(const std::string& scene) {
  HypersimTruth truth{at::zeros({kHypersimHeight, kHypersimWidth, 3}, at::kDouble),
                      at::zeros({kHypersimHeight, kHypersimWidth}, at::kDouble)};
  auto points = truth.points.accessor<double, 3>();
  auto distance = truth.distance.accessor<double, 2>();
  for (int row = 0; row < kHypersimHeight; ++row)
    for (int column = 0; column < kHypersimWidth; ++column) {
      const Vec3 h = hypersim_ray(kCamFromUv.at(scene), column, row);
      const Vec3 ray{h[0], -h[1], -h[2]};  // Hypersim's axes -> ours
      const double d = box_hit(ray, {-2.0, -1.2, -1.0}, {3.0, 1.4, 4.5}).distance;
      const double norm = std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + ray[2] * ray[2]);
      distance[row][column] = d;
      for (int a = 0; a < 3; ++a) points[row][column][a] = d * ray[a] / norm;
    }
  return truth;
}

// An HDR colour image whose values float16 holds exactly: red (column + 1) / 64, green
// (row + 1) / 32, blue 0.5; one pixel brighter than 1 after tone mapping, one negative.
at::Tensor hdr_colour() {
  at::Tensor rgb = at::empty({kHypersimHeight, kHypersimWidth, 3}, at::kFloat);
  auto values = rgb.accessor<float, 3>();
  for (int row = 0; row < kHypersimHeight; ++row)
    for (int column = 0; column < kHypersimWidth; ++column) {
      values[row][column][0] = static_cast<float>(column + 1) / 64;
      values[row][column][1] = static_cast<float>(row + 1) / 32;
      values[row][column][2] = 0.5f;
    }
  values[20][30][2] = 6.0f;
  values[21][30][0] = -0.25f;
  return rgb;
}

// scene_generate_images_tonemap.py, step by step.
at::Tensor expected_tonemap(const at::Tensor& rgb, const at::Tensor& valid) {
  std::vector<double> brightness;
  auto values = rgb.accessor<float, 3>();
  auto keep = valid.accessor<bool, 2>();
  for (int row = 0; row < kHypersimHeight; ++row)
    for (int column = 0; column < kHypersimWidth; ++column)
      if (keep[row][column])
        brightness.push_back(0.3 * values[row][column][0] + 0.59 * values[row][column][1] +
                             0.11 * values[row][column][2]);
  std::sort(brightness.begin(), brightness.end());
  const double rank = 0.9 * static_cast<double>(brightness.size() - 1);
  const auto low = static_cast<std::size_t>(rank);
  const double p90 = brightness[low] + (brightness[low + 1] - brightness[low]) * (rank - low);
  const double scale = std::pow(0.8, 2.2) / p90;
  return (rgb.to(at::kDouble) * scale).clamp_min(0).pow(1 / 2.2).clamp(0, 1);
}

class Hypersim : public RenderedFormats {
 protected:
  // A frame of `scene`: distances (NaN in a top-left block: no geometry), entity ids (-1 there),
  // HDR colour.
  void write_frame(const std::string& scene, const std::string& camera, int frame) {
    char name[32];
    std::snprintf(name, sizeof name, "frame.%04d", frame);
    const fs::path images = root_ / scene / "images";
    const HypersimTruth truth = hypersim_truth(scene);
    at::Tensor distance = truth.distance.to(at::kFloat);
    at::Tensor ids = at::full({kHypersimHeight, kHypersimWidth}, 7, at::kInt);
    distance.slice(0, 0, 4).slice(1, 0, 10).fill_(std::numeric_limits<float>::quiet_NaN());
    ids.slice(0, 0, 4).slice(1, 0, 10).fill_(-1);
    const fs::path geometry = images / ("scene_" + camera + "_geometry_hdf5");
    write_float16(geometry / (std::string(name) + ".depth_meters.hdf5"), distance);
    write_int16(geometry / (std::string(name) + ".render_entity_id.hdf5"), ids);
    write_float16(
        images / ("scene_" + camera + "_final_hdf5") / (std::string(name) + ".color.hdf5"),
        hdr_colour());
  }
  static at::Tensor labelled() {
    at::Tensor mask = at::ones({kHypersimHeight, kHypersimWidth}, at::kBool);
    mask.slice(0, 0, 4).slice(1, 0, 10).fill_(false);
    return mask;
  }
  // float16 keeps 11 significant bits: a distance is within 2^-11 of itself (2^-10 allowed).
  static at::Tensor tolerance(const HypersimTruth& truth) {
    return truth.distance * std::ldexp(1.0, -10) + 1e-5;
  }
  void write_scenes() {
    write_text(root_ / "metadata_camera_parameters.csv",
               camera_csv({"ai_001_001", "ai_019_007", "ai_026_007", "ai_038_009"}));
    write_frame("ai_001_001", "cam_00", 0);
    write_frame("ai_001_001", "cam_00", 1);
    write_frame("ai_019_007", "cam_00", 0);
    write_frame("ai_026_007", "cam_01", 3);
    write_frame("ai_038_009", "cam_00", 0);
  }
  std::string item(const std::string& scene, const std::string& camera, int frame) {
    char name[32];
    std::snprintf(name, sizeof name, "frame.%04d.color.hdf5", frame);
    return scene + "/images/scene_" + camera + "_final_hdf5/" + name;
  }
};

TEST_F(Hypersim, DistanceAlongTheCsvRaysOfStandardAndShiftedCameras) {
  write_scenes();
  const auto dataset = open_dataset("hypersim", {root_.string()});
  // The two-axis tilt (ai_019_007) is left out: no exact camera model.
  ASSERT_EQ(dataset->size(), 4);
  EXPECT_EQ(dataset->item_name({0, 0}), item("ai_001_001", "cam_00", 0));
  EXPECT_EQ(dataset->item_name({2, 0}), item("ai_026_007", "cam_01", 3));
  EXPECT_EQ(
      dataset->item_sources({2, 0}),
      (std::vector<std::string>{
          (root_ / item("ai_026_007", "cam_01", 3)).string(),
          (root_ / "ai_026_007/images/scene_cam_01_geometry_hdf5/frame.0003.depth_meters.hdf5")
              .string(),
          (root_ / "ai_026_007/images/scene_cam_01_geometry_hdf5/frame.0003.render_entity_id.hdf5")
              .string()}));
  for (const auto& [index, scene] : {std::pair{0, "ai_001_001"}, std::pair{2, "ai_026_007"}}) {
    SCOPED_TRACE(scene);
    const Sample sample = dataset->item({index, 0});
    EXPECT_EQ(sample.camera.model_name(), "PINHOLE");
    // Square pixels; the sample's frame is Hypersim's (y, z negated): points compared directly.
    EXPECT_NEAR(sample.camera.params()[0], sample.camera.params()[1], 1e-9);
    const HypersimTruth truth = hypersim_truth(scene);
    expect_points(sample, truth.points, tolerance(truth), labelled());
    EXPECT_FALSE(sample.sparse_labels);
  }
  // The standard camera: a 60-degree horizontal field of view (M_cam_from_uv_00 is tan 30 degrees
  // as a float32), centred.
  const std::vector<double> standard = dataset->item({0, 0}).camera.params();
  EXPECT_NEAR(standard[0], 32 / 0.5773502886169104, 1e-9);
  EXPECT_NEAR(standard[0], 32 / std::tan(M_PI / 6), 1e-5);
  EXPECT_NEAR(standard[2], 32, 1e-9);
  EXPECT_NEAR(standard[3], 24, 1e-9);
  // The shift: cx off the centre by M_cam_from_uv_02 / _00 of half the width.
  const std::vector<double> shifted = dataset->item({2, 0}).camera.params();
  EXPECT_NEAR(shifted[2], 32 * (1 + 0.011547518714890601 / 0.5773759486498881), 1e-6);
}

TEST_F(Hypersim, ATiltedImagePlaneIsAnExactPinholeInItsOwnFrame) {
  write_scenes();
  const auto dataset = open_dataset("hypersim", {root_.string()});
  ASSERT_EQ(dataset->item_name({3, 0}), item("ai_038_009", "cam_00", 0));
  const Sample sample = dataset->item({3, 0});
  EXPECT_EQ(sample.camera.model_name(), "PINHOLE");
  EXPECT_NEAR(sample.camera.params()[0], sample.camera.params()[1], 1e-9);
  // The image plane holds Hypersim's x axis and (0, b, c) (M's column of v, b = M_11,
  // c = M_21): the pinhole's axes, in ours, are x, (0, b, c) / n and (0, -c, b) / n.
  const std::array<double, 9>& m = kCamFromUv.at("ai_038_009");
  const double b = m[4], c = m[7], n = std::hypot(b, c);
  const at::Tensor frame =
      at::tensor({1.0, 0.0, 0.0, 0.0, b / n, c / n, 0.0, -c / n, b / n}, at::kDouble).view({3, 3});
  const HypersimTruth truth = hypersim_truth("ai_038_009");
  const at::Tensor points = at::matmul(truth.points, frame.t());
  expect_points(sample, points, tolerance(truth), labelled());
  // In Hypersim's own frame the same points are off by metres: the turn is real (22 degrees).
  EXPECT_GT((points - truth.points).norm(2, -1).max().item<double>(), 1.0);

  // tilt_shift=exclude keeps only the scenes whose pinhole is in Hypersim's frame.
  DatasetLocation exclude{root_.string()};
  exclude.options["tilt_shift"] = "exclude";
  const auto untilted = open_dataset("hypersim", exclude);
  ASSERT_EQ(untilted->size(), 3);
  EXPECT_EQ(untilted->item_name({2, 0}), item("ai_026_007", "cam_01", 3));
  exclude.options["tilt_shift"] = "nearest";
  EXPECT_HAS(open_error("hypersim", exclude), "option tilt_shift=nearest: expected one of");

  // A list naming a frame of the two-axis tilt: its item fails, naming the skew.
  write_text(root_ / "list.txt", item("ai_019_007", "cam_00", 0) + "\n");
  DatasetLocation listed{root_.string()};
  listed.split = (root_ / "list.txt").string();
  const auto skewed = open_dataset("hypersim", listed);
  ASSERT_EQ(skewed->size(), 1);
  test::expect_error<SampleError>(
      [&] {
        skewed->item({0, 0});
      },
      {"ai_019_007", "metadata_camera_parameters.csv", "has a skew"});
}

TEST_F(Hypersim, ColourToneMappedAsTheDatasetsScriptOrItsPreview) {
  write_scenes();
  const auto dataset = open_dataset("hypersim", {root_.string()});
  const Sample sample = dataset->item({0, 0});
  const at::Tensor expected = expected_tonemap(hdr_colour(), labelled());
  EXPECT_LE((sample.image.to(at::kDouble) - expected).abs().max().item<double>(), 1e-5);
  EXPECT_EQ(sample.image[20][30][2].item<float>(), 1.0f);  // clipped
  EXPECT_EQ(sample.image[21][30][0].item<float>(), 0.0f);  // negative -> 0
  EXPECT_GT(sample.image[40][50][0].item<float>(), 0.5f);  // not a copy of the raw values

#ifdef OMNIPOINT_WITH_OPENCV
  if (!io::image_io_available()) return;
  // color=preview: the tonemap.jpg previews, the same distances.
  const fs::path preview =
      root_ / "ai_001_001/images/scene_cam_00_final_preview/frame.0000.tonemap.jpg";
  fs::create_directories(preview.parent_path());
  ASSERT_TRUE(cv::imwrite(preview.string(), cv::Mat(kHypersimHeight, kHypersimWidth, CV_8UC3,
                                                    cv::Scalar(40, 90, 200))));
  DatasetLocation location{root_.string()};
  location.options["color"] = "preview";
  const auto previews = open_dataset("hypersim", location);
  ASSERT_EQ(previews->size(), 1);
  const Sample from_preview = previews->item({0, 0});
  EXPECT_NEAR(from_preview.image[5][5][0].item<float>(), 200 / 255.0, 0.02);  // RGB from BGR
  EXPECT_TRUE(at::equal(from_preview.distance, sample.distance));
  EXPECT_EQ(previews->item_sources({0, 0}).size(), 2u);
  ASSERT_TRUE(cv::imwrite(preview.string(), cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 2, 3))));
  test::expect_error<SampleError>(
      [&] {
        previews->item({0, 0});
      },
      {preview.string(), "32x24, but the camera is 64x48"});
#endif
}

TEST_F(Hypersim, NamedSplitsFromTheSplitCsvAndSequences) {
  write_scenes();
  write_text(root_ / "metadata_images_split_scene_v1.csv",
             "scene_name,camera_name,frame_id,included_in_public_release,exclude_reason,"
             "split_partition_name\n"
             "ai_001_001,cam_00,0,True,,train\n"
             "ai_001_001,cam_00,1,False,bad frame,train\n"
             "ai_026_007,cam_01,3,True,,test\n"
             "ai_038_009,cam_00,0,True,,val\n");
  const auto names_in = [&](const std::string& split) {
    DatasetLocation location{root_.string()};
    location.split = split;
    const auto dataset = open_dataset("hypersim", location);
    std::vector<std::string> names;
    for (int64_t i = 0; i < dataset->size(); ++i) names.push_back(dataset->item_name({i, 0}));
    return names;
  };
  EXPECT_EQ(names_in("train"), std::vector<std::string>{item("ai_001_001", "cam_00", 0)});
  EXPECT_EQ(names_in("val"), std::vector<std::string>{item("ai_038_009", "cam_00", 0)});
  EXPECT_EQ(names_in("test"), std::vector<std::string>{item("ai_026_007", "cam_01", 3)});

  DatasetLocation sequence{root_.string()};
  sequence.options["sequence"] = "ai_001_001,ai_026_007/cam_01";
  EXPECT_EQ(open_dataset("hypersim", sequence)->size(), 3);
  sequence.options["sequence"] = "ai_026_007/cam_00";
  EXPECT_HAS(open_error("hypersim", sequence), "holds no items");

  // A split CSV row of the wrong field count: the file and its line.
  write_text(root_ / "metadata_images_split_scene_v1.csv",
             "scene_name,camera_name,frame_id,included_in_public_release,exclude_reason,"
             "split_partition_name\nai_001_001,cam_00,0,True,train\n");
  DatasetLocation train{root_.string()};
  train.split = "train";
  const std::string error = open_error("hypersim", train);
  EXPECT_HAS(error, "metadata_images_split_scene_v1.csv:2: expected 6 fields");
}

TEST_F(Hypersim, MalformedFilesGiveOneErrorNamingTheFile) {
  write_scenes();
  const auto dataset = open_dataset("hypersim", {root_.string()});
  const fs::path depth =
      root_ / "ai_001_001/images/scene_cam_00_geometry_hdf5/frame.0000.depth_meters.hdf5";
  // The wrong size.
  write_float16(depth, at::ones({40, kHypersimWidth}));
  test::expect_error<SampleError>(
      [&] {
        dataset->item({0, 0});
      },
      {item("ai_001_001", "cam_00", 0), depth.string(), "64x40, but the camera (", "is 64x48"});
  // A colour image for a distance image.
  write_float16(depth, at::ones({kHypersimHeight, kHypersimWidth, 3}));
  test::expect_error<SampleError>(
      [&] {
        dataset->item({0, 0});
      },
      {depth.string(), "expected a 2-D distance image"});
  // Another array name, then not HDF5 at all, then no file.
  const hid_t type = float16_type();
  write_hdf5(depth, at::ones({kHypersimHeight, kHypersimWidth}), type, "depth");
  H5Tclose(type);
  test::expect_error<SampleError>(
      [&] {
        dataset->item({0, 0});
      },
      {depth.string(), "no dataset \"dataset\""});
  write_text(depth, "not hdf5");
  test::expect_error<SampleError>(
      [&] {
        dataset->item({0, 0});
      },
      {depth.string(), "not an HDF5 file"});
  fs::remove(depth);
  test::expect_error<SampleError>(
      [&] {
        dataset->item({0, 0});
      },
      {depth.string(), "cannot open the file"});
  // Entity ids of another size than the colour.
  write_int16(
      root_ / "ai_001_001/images/scene_cam_00_geometry_hdf5/frame.0001.render_entity_id.hdf5",
      at::zeros({kHypersimHeight, 8}, at::kInt));
  test::expect_error<SampleError>(
      [&] {
        dataset->item({1, 0});
      },
      {"frame.0001.render_entity_id.hdf5: 8x48, but", "frame.0001.color.hdf5 is 64x48"});

  // A list naming a frame whose files are missing: the list, its line, the file.
  write_text(root_ / "list.txt",
             item("ai_038_009", "cam_00", 0) + "\n" + item("ai_038_009", "cam_00", 9) + "\n");
  DatasetLocation listed{root_.string()};
  listed.split = (root_ / "list.txt").string();
  const std::string missing = open_error("hypersim", listed);
  EXPECT_HAS(missing, "list.txt:2: names");
  EXPECT_HAS(missing, "frame.0009.color.hdf5, which does not exist");

  // The camera CSV: a scene not in it, a missing column, a bad number, no file.
  write_text(root_ / "metadata_camera_parameters.csv", camera_csv({"ai_026_007", "ai_038_009"}));
  test::expect_error<SampleError>(
      [&] {
        open_dataset("hypersim", {root_.string()})->item({1, 0});
      },
      {"metadata_camera_parameters.csv: no row for the scene ai_001_001"});
  write_text(root_ / "metadata_camera_parameters.csv",
             camera_csv({"ai_001_001"}, "M_cam_from_uv_21"));
  EXPECT_HAS(open_error("hypersim", {root_.string()}),
             "metadata_camera_parameters.csv:1: no column M_cam_from_uv_21");
  std::string text = camera_csv({"ai_001_001"});
  text.replace(text.find("0.57735"), 7, "0.5x735");
  write_text(root_ / "metadata_camera_parameters.csv", text);
  EXPECT_HAS(open_error("hypersim", {root_.string()}),
             "metadata_camera_parameters.csv:2: M_cam_from_uv_00 \"0.5x73502886169104\" is not a "
             "number");
  fs::remove(root_ / "metadata_camera_parameters.csv");
  EXPECT_HAS(open_error("hypersim", {root_.string()}), "metadata_camera_parameters.csv");
  DatasetLocation elsewhere{root_.string()};
  elsewhere.options["camera_csv"] = (root_ / "cameras.csv").string();
  write_text(root_ / "cameras.csv",
             camera_csv({"ai_001_001", "ai_019_007", "ai_026_007", "ai_038_009"}));
  EXPECT_EQ(open_dataset("hypersim", elsewhere)->size(), 4);
}

#endif  // OMNIPOINT_WITH_HDF5

TEST(RenderedText, HypersimCsvsParseStrictly) {
  const auto cameras = formats::parse_hypersim_cameras(
      "scene_name,settings_output_img_height,settings_output_img_width,x,"
      "M_cam_from_uv_00,M_cam_from_uv_01,M_cam_from_uv_02,M_cam_from_uv_10,M_cam_from_uv_11,"
      "M_cam_from_uv_12,M_cam_from_uv_20,M_cam_from_uv_21,M_cam_from_uv_22\r\n"
      "ai_001_001,768.0,1024.0,,0.5,0,0,0,0.4,-0.0,0,0,-1\r\n",
      "cameras.csv");
  ASSERT_EQ(cameras.size(), 1u);
  EXPECT_EQ(cameras.at("ai_001_001").width, 1024);
  EXPECT_EQ(cameras.at("ai_001_001").height, 768);
  EXPECT_EQ(cameras.at("ai_001_001").cam_from_uv[4], 0.4);
  EXPECT_EQ(cameras.at("ai_001_001").cam_from_uv[8], -1);
  const auto fails = [](const std::function<void()>& parse, const std::string& part) {
    test::expect_error<std::runtime_error>(parse, {part});
  };
  const std::string header =
      "scene_name,settings_output_img_height,settings_output_img_width,M_cam_from_uv_00,"
      "M_cam_from_uv_01,M_cam_from_uv_02,M_cam_from_uv_10,M_cam_from_uv_11,M_cam_from_uv_12,"
      "M_cam_from_uv_20,M_cam_from_uv_21,M_cam_from_uv_22\n";
  fails([&] { formats::parse_hypersim_cameras(header + "a,768.5,1024,1,0,0,0,1,0,0,0,-1\n", "c"); },
        "c:2: settings_output_img_height \"768.5\" is not a non-negative integer");
  fails([&] { formats::parse_hypersim_cameras(header + "a,768,1024,1,0,0,0,1,0,0,0\n", "c"); },
        "c:2: expected 12 fields (as the header), got 11");
  fails(
      [&] {
        formats::parse_hypersim_cameras(
            header + "a,768,1024,1,0,0,0,1,0,0,0,-1\na,768,1024,1,0,0,0,1,0,0,0,-1\n", "c");
      },
      "c:3: the scene a appears twice");
  fails([&] { formats::parse_hypersim_cameras("\"scene_name\"\n", "c"); }, "quoted fields");
  fails([&] { formats::parse_hypersim_cameras("", "c"); }, "c: no header line");

  const auto split = formats::parse_hypersim_split(
      "scene_name,camera_name,frame_id,included_in_public_release,exclude_reason,"
      "split_partition_name\nai_001_001,cam_00,12,True,,val\nai_001_001,cam_00,13,False,x,\n",
      "split.csv");
  ASSERT_EQ(split.size(), 1u);
  EXPECT_EQ(split.at({"ai_001_001", "cam_00", 12}), "val");
  fails(
      [&] {
        formats::parse_hypersim_split(
            "scene_name,camera_name,frame_id,included_in_public_release,split_partition_name\n"
            "a,cam_00,1,Yes,train\n",
            "s");
      },
      "s:2: included_in_public_release \"Yes\" is neither True nor False");
  fails(
      [&] {
        formats::parse_hypersim_split(
            "scene_name,camera_name,frame_id,included_in_public_release,split_partition_name\n"
            "a,cam_00,1,True,holdout\n",
            "s");
      },
      "split_partition_name \"holdout\" is not train, val or test");
  fails([&] { formats::parse_hypersim_split("scene_name,frame_id\n", "s"); },
        "s:1: no column camera_name");
}

TEST(RenderedText, Vkitti2IntrinsicsParseStrictly) {
  const auto intrinsics = formats::parse_vkitti2_intrinsics(
      "frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n0 0 725.0087 725.0087 620.5 187\n"
      "0 1 725.0087 725.0087 620.5 187\r\n\n1 0 700 701 600.25 180.5\n",
      "intrinsic.txt");
  ASSERT_EQ(intrinsics.size(), 3u);
  EXPECT_EQ(intrinsics.at({1, 0}).fy, 701);
  EXPECT_EQ(intrinsics.at({0, 1}).cx, 620.5);
  const auto fails = [](const std::string& text, const std::string& part) {
    test::expect_error<std::runtime_error>(
        [&] { formats::parse_vkitti2_intrinsics(text, "intrinsic.txt"); }, {part});
  };
  const std::string header = "frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n";
  fails("0 0 725 725 620.5 187\n", "intrinsic.txt: expected the header line");
  fails(header + "0 0 725 725 620.5\n", "intrinsic.txt:2: expected 6 fields");
  fails(header + "0 0 725 -725 620.5 187\n", "intrinsic.txt:2: fx and fy must be > 0");
  fails(header + "0.5 0 725 725 620.5 187\n", "frame \"0.5\" is not a non-negative integer");
  fails(header + "0 0 725 725 620.5 1e999\n", "cy \"1e999\" is not a number");
  fails(header + "3 1 725 725 620.5 187\n3 1 725 725 620.5 187\n",
        "intrinsic.txt:3: frame 3 of camera 1 is given twice");
}

// ---- Virtual KITTI 2 ----

#ifdef OMNIPOINT_WITH_OPENCV

constexpr int kVkittiWidth = 124, kVkittiHeight = 38;

// A street: the road 1.65 m below the camera, walls at x = -7 and 8 m, a far wall at 80 m; rays
// that leave upwards (past y = -4 m) see the sky. The file's K, with pixel i's centre at i.
struct StreetTruth {
  at::Tensor points, z, sky;
};
StreetTruth street_truth(const formats::PinholeIntrinsics& k) {
  StreetTruth truth{at::zeros({kVkittiHeight, kVkittiWidth, 3}, at::kDouble),
                    at::zeros({kVkittiHeight, kVkittiWidth}, at::kDouble),
                    at::zeros({kVkittiHeight, kVkittiWidth}, at::kBool)};
  auto points = truth.points.accessor<double, 3>();
  auto z = truth.z.accessor<double, 2>();
  auto sky = truth.sky.accessor<bool, 2>();
  for (int row = 0; row < kVkittiHeight; ++row)
    for (int column = 0; column < kVkittiWidth; ++column) {
      const Vec3 ray{(column - k.cx) / k.fx, (row - k.cy) / k.fy, 1.0};
      const Hit hit = box_hit(ray, {-7.0, -4.0, -1.0}, {8.0, 1.65, 80.0});
      const double norm = std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + 1);
      for (int a = 0; a < 3; ++a) points[row][column][a] = hit.distance * ray[a] / norm;
      z[row][column] = hit.distance / norm;
      sky[row][column] = hit.axis == 1 && hit.side == 0;
    }
  return truth;
}

void write_image(const fs::path& path, const cv::Mat& image) {
  fs::create_directories(path.parent_path());
  ASSERT_TRUE(cv::imwrite(path.string(), image)) << path;
}

// The z-buffer in centimetres, 65535 on the sky.
cv::Mat depth_png(const StreetTruth& truth) {
  cv::Mat depth(kVkittiHeight, kVkittiWidth, CV_16UC1);
  auto z = truth.z.accessor<double, 2>();
  auto sky = truth.sky.accessor<bool, 2>();
  for (int row = 0; row < kVkittiHeight; ++row)
    for (int column = 0; column < kVkittiWidth; ++column)
      depth.at<uint16_t>(row, column) =
          sky[row][column] ? 65535 : static_cast<uint16_t>(std::lround(z[row][column] * 100));
  return depth;
}

const formats::PinholeIntrinsics kLeft{72.5, 72.5, 61.5, 18.5};    // (W - 1) / 2, (H - 1) / 2
const formats::PinholeIntrinsics kRight{80.0, 79.0, 60.25, 17.0};  // frame 1 of Camera_1

class Vkitti2 : public RenderedFormats {
 protected:
  void SetUp() override {
    RenderedFormats::SetUp();
    if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  }
  void write_frame(const std::string& sequence, int camera, int frame,
                   const formats::PinholeIntrinsics& k) {
    char number[16];
    std::snprintf(number, sizeof number, "%05d", frame);
    const fs::path frames = root_ / sequence / "frames";
    const std::string folder = "Camera_" + std::to_string(camera);
    write_image(frames / "rgb" / folder / ("rgb_" + std::string(number) + ".jpg"),
                cv::Mat(kVkittiHeight, kVkittiWidth, CV_8UC3, cv::Scalar(30, 60, 90)));
    write_image(frames / "depth" / folder / ("depth_" + std::string(number) + ".png"),
                depth_png(street_truth(k)));
  }
  static std::string intrinsics_line(int frame, int camera, const formats::PinholeIntrinsics& k) {
    char line[128];
    std::snprintf(line, sizeof line, "%d %d %g %g %g %g\n", frame, camera, k.fx, k.fy, k.cx, k.cy);
    return line;
  }
  void write_scenes() {
    const std::string header = "frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n";
    for (const std::string sequence : {"Scene01/clone", "Scene02/fog"}) {
      write_text(root_ / sequence / "intrinsic.txt",
                 header + intrinsics_line(0, 0, kLeft) + intrinsics_line(0, 1, kLeft) +
                     intrinsics_line(1, 0, kLeft) + intrinsics_line(1, 1, kRight));
      for (int frame = 0; frame < 2; ++frame) write_frame(sequence, 0, frame, kLeft);
    }
    write_frame("Scene01/clone", 1, 1, kRight);
  }
  // The z-buffer's centimetres: a point is within 0.5 cm of z, times |ray| / z, of the truth.
  static at::Tensor tolerance(const StreetTruth& truth) {
    return 0.005 * truth.points.norm(2, -1) / truth.z + 1e-5;
  }
};

TEST_F(Vkitti2, CentimetreZDepthAlongIntegerCentredPinholeRays) {
  write_scenes();
  const auto dataset = open_dataset("vkitti2", {root_.string()});
  ASSERT_EQ(dataset->size(), 4);
  EXPECT_EQ(dataset->item_name({1, 0}), "Scene01/clone/frames/rgb/Camera_0/rgb_00001.jpg");
  EXPECT_EQ(dataset->item_sources({1, 0}),
            (std::vector<std::string>{
                (root_ / "Scene01/clone/frames/rgb/Camera_0/rgb_00001.jpg").string(),
                (root_ / "Scene01/clone/frames/depth/Camera_0/depth_00001.png").string(),
                (root_ / "Scene01/clone/intrinsic.txt").string()}));
  const Sample sample = dataset->item({1, 0});
  EXPECT_EQ(sample.camera.to_spec(), "PINHOLE 124 38 72.5 72.5 62 19");
  const StreetTruth truth = street_truth(kLeft);
  ASSERT_TRUE(truth.sky.any().item<bool>());
  expect_points(sample, truth.points, tolerance(truth), ~truth.sky);

  // The right camera, its own frame's K.
  DatasetLocation right{root_.string()};
  right.options["camera"] = "Camera_1";
  const auto rights = open_dataset("vkitti2", right);
  ASSERT_EQ(rights->size(), 1);
  const StreetTruth right_truth = street_truth(kRight);
  expect_points(rights->item({0, 0}), right_truth.points, tolerance(right_truth), ~right_truth.sky);

  // principal_point=corner reads the file's cx, cy unshifted: points move by centimetres.
  DatasetLocation corner{root_.string()};
  corner.options["principal_point"] = "corner";
  const Sample unshifted = open_dataset("vkitti2", corner)->item({1, 0});
  EXPECT_EQ(unshifted.camera.to_spec(), "PINHOLE 124 38 72.5 72.5 61.5 18.5");
  const at::Tensor moved = unshifted.distance.to(at::kDouble).unsqueeze(-1) *
                               unshifted.camera.ray_map(at::kDouble).rays -
                           truth.points;
  EXPECT_GT(at::where(sample.mask, moved.norm(2, -1), at::zeros_like(truth.z)).max().item<double>(),
            0.2);

  // Sequences: a scene, or a scene's variation.
  DatasetLocation sequence{root_.string()};
  sequence.options["sequence"] = "Scene02";
  EXPECT_EQ(open_dataset("vkitti2", sequence)->size(), 2);
  sequence.options["sequence"] = "Scene01/clone,Scene02/fog";
  EXPECT_EQ(open_dataset("vkitti2", sequence)->size(), 4);
  sequence.options["sequence"] = "Scene01/fog";
  EXPECT_HAS(open_error("vkitti2", sequence), "holds no items");
  DatasetLocation bad{root_.string()};
  bad.options["camera"] = "Camera_2";
  EXPECT_HAS(open_error("vkitti2", bad), "option camera=Camera_2: expected one of Camera_0");
}

TEST_F(Vkitti2, MalformedFilesGiveOneErrorNamingTheFile) {
  write_scenes();
  const auto dataset = open_dataset("vkitti2", {root_.string()});
  const fs::path depth = root_ / "Scene01/clone/frames/depth/Camera_0/depth_00000.png";
  write_image(depth, cv::Mat(kVkittiHeight, kVkittiWidth, CV_8UC1, cv::Scalar(9)));
  test::expect_error<SampleError>(
      [&] {
        dataset->item({0, 0});
      },
      {"Scene01/clone/frames/rgb/Camera_0/rgb_00000.jpg", depth.string(),
       "expected a 16-bit grey PNG, got an 8-bit grey one"});
  write_image(depth, cv::Mat(kVkittiHeight, 100, CV_16UC1, cv::Scalar(900)));
  test::expect_error<SampleError>(
      [&] {
        dataset->item({0, 0});
      },
      {depth.string(), "100x38, but the image is 124x38"});

  // intrinsic.txt without the frame, then with a short line.
  const fs::path intrinsics = root_ / "Scene02/fog/intrinsic.txt";
  write_text(intrinsics,
             "frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n" + intrinsics_line(0, 0, kLeft));
  test::expect_error<SampleError>(
      [&] {
        dataset->item({3, 0});
      },
      {intrinsics.string() + ": no line for frame 1 of camera 0"});
  write_text(intrinsics, "frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n0 0 72.5 72.5 61.5\n");
  test::expect_error<SampleError>(
      [&] {
        dataset->item({2, 0});
      },
      {intrinsics.string() + ":2: expected 6 fields"});
  fs::remove(intrinsics);
  test::expect_error<SampleError>([&] { dataset->item({2, 0}); }, {intrinsics.string()});

  // A split list naming a frame that is not there.
  write_text(root_ / "train.txt",
             "Scene01/clone/frames/rgb/Camera_0/rgb_00001.jpg\n"
             "Scene01/clone/frames/rgb/Camera_0/rgb_00007.jpg\n");
  DatasetLocation listed{root_.string()};
  listed.split = (root_ / "train.txt").string();
  const std::string missing = open_error("vkitti2", listed);
  EXPECT_HAS(missing, "train.txt:2: names");
  EXPECT_HAS(missing, "rgb_00007.jpg, which does not exist (and 1 more missing files");
}

#endif  // OMNIPOINT_WITH_OPENCV

}  // namespace
}  // namespace omnipoint::data
