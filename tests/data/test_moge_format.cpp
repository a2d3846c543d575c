// MoGe's benchmark layout: the log depth code, PNG text chunks, and reading an instance.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "omnipoint/data/moge_format.h"
#include "omnipoint/data/png_text.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/imgcodecs.hpp>
#endif

namespace omnipoint::data {
namespace {
namespace fs = std::filesystem;

at::Tensor example_depth() {
  auto depth =
      at::linspace(0.5, 80.0, int64_t{12} * 10, at::kDouble).reshape({12, 10}).to(at::kFloat);
  depth[0][1] = NAN;
  depth[1][2] = INFINITY;
  return depth;
}

TEST(MogeDepth, EncodeDecodeRoundTripWithinOneCodeStep) {
  const auto depth = example_depth();
  const auto code = encode_moge_depth(depth);
  EXPECT_FLOAT_EQ(code.near, 0.5);
  EXPECT_NEAR(code.far, 80.0, 1e-5);
  EXPECT_EQ(code.values[0][1].item<int>(), 0);
  EXPECT_EQ(code.values[1][2].item<int>(), 65535);
  EXPECT_EQ(code.values.min().item<int>(), 0);
  const auto back = decode_moge_depth(code);
  EXPECT_TRUE(std::isnan(back[0][1].item<float>()));
  EXPECT_TRUE(std::isinf(back[1][2].item<float>()));
  const auto finite = at::isfinite(depth);
  // One step of the code is a factor (far/near)^(1/65533): half a step of relative error.
  const double half_step = std::pow(80.0 / 0.5, 0.5 / 65533) - 1;
  const auto rel = ((back - depth) / depth).masked_select(finite).abs().max().item<double>();
  EXPECT_LE(rel, half_step * 1.01 + 1e-6);
  EXPECT_GT(rel, 0.0);
  // The extremes map to the first and last finite codes.
  EXPECT_EQ(code.values.masked_select(finite).min().item<int>(), 1);
  EXPECT_EQ(code.values.masked_select(finite).max().item<int>(), 65534);
  EXPECT_THROW(encode_moge_depth(at::full({2, 2}, NAN)), std::invalid_argument);
  EXPECT_THROW(encode_moge_depth(-at::ones({2, 2})), std::invalid_argument);
}

TEST(MogeDepth, FarIsCappedByTheMaximumRange) {
  auto depth = at::tensor({1e-3, 1.0, 1e4}, at::kDouble).reshape({1, 3});
  const auto code = encode_moge_depth(depth, 1e5);
  EXPECT_NEAR(code.far, 1e2, 1e-9);
  EXPECT_EQ(code.values[0][2].item<int>(), 65534);  // clipped to far
}

#ifdef OMNIPOINT_WITH_OPENCV
TEST(MogeDepth, PngFileRoundTripKeepsTextChunksAndPixels) {
  const auto dir = fs::temp_directory_path() / "omnipoint_moge_depth";
  fs::create_directories(dir);
  const auto path = (dir / "depth.png").string();
  const auto depth = example_depth();
  write_moge_depth(path, depth);
  const auto text = read_png_text(io::read_file(path), path);
  ASSERT_TRUE(text.count("near") && text.count("far"));
  EXPECT_DOUBLE_EQ(std::stod(text.at("near")), 0.5);
  // OpenCV still decodes the file (our chunks are well-formed) and sees the 16-bit codes.
  const auto cv = cv::imread(path, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(cv.depth(), CV_16U);
  const auto code = encode_moge_depth(depth);
  EXPECT_EQ(cv.at<uint16_t>(5, 7), code.values[5][7].item<int>());
  const auto back = read_moge_depth(path);
  EXPECT_TRUE(at::allclose(back.masked_select(at::isfinite(depth)),
                           decode_moge_depth(code).masked_select(at::isfinite(depth))));
  EXPECT_TRUE(std::isinf(back[1][2].item<float>()));

  // Missing text chunks or a corrupt stream are errors naming the file.
  io::write_image_png(path, code.values);
  EXPECT_THROW(read_moge_depth(path), std::runtime_error);
  std::string bytes = add_png_text(io::read_file(path), {{"near", "1"}});
  bytes[bytes.size() / 2] ^= 0x55;
  EXPECT_THROW(read_png_text(bytes, "spoilt"), std::runtime_error);
  EXPECT_THROW(read_png_text("not a png", "x"), std::runtime_error);
}

TEST(MogeDepth, ReadsAnInstanceFolderAsAPinholeSample) {
  const auto root = fs::temp_directory_path() / "omnipoint_moge_bench";
  fs::remove_all(root);
  fs::create_directories(root / "scene_a");
  const int64_t h = 12, w = 16;
  io::write_image_png((root / "scene_a" / "image.png").string(), at::rand({h, w, 3}));
  // image.jpg: the same picture through OpenCV's JPEG encoder.
  const auto png = cv::imread((root / "scene_a" / "image.png").string());
  cv::imwrite((root / "scene_a" / "image.jpg").string(), png);
  auto depth = at::full({h, w}, 3.0f);
  depth[0][0] = NAN;
  write_moge_depth((root / "scene_a" / "depth.png").string(), depth);
  std::ofstream(root / "scene_a" / "meta.json")
      << R"({"intrinsics": [[0.75, 0, 0.5], [0, 1.0, 0.5], [0, 0, 1]]})";
  std::ofstream(root / ".index.txt") << "scene_a\n";
  const auto instances = list_moge_instances(root.string());
  ASSERT_EQ(instances.size(), 1u);
  const auto s = read_moge_instance(instances[0], false);
  EXPECT_EQ(s.camera.to_spec(), camera::make_camera("PINHOLE", w, h, {12, 12, 8, 6}).to_spec());
  EXPECT_FALSE(s.mask[0][0].item<bool>());
  EXPECT_EQ(s.mask.sum().item<int64_t>(), h * w - 1);
  // Planar depth 3 everywhere: distance * ray.z == 3.
  const auto z = s.distance * s.camera.ray_map(at::kFloat).rays.select(-1, 2);
  EXPECT_LT((z - 3).masked_select(s.mask).abs().max().item<double>(), 1e-3);
}
#endif

}  // namespace
}  // namespace omnipoint::data
