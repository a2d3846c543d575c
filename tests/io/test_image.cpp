#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "omnipoint/io/image.h"

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#endif

namespace fs = std::filesystem;
using namespace omnipoint::io;

namespace {

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("omnipoint_image_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

}  // namespace

#ifdef OMNIPOINT_WITH_OPENCV

namespace {

// A (rows, cols) OpenCV image of `type` whose value at (r, c, k) is f(r, c, k).
template <typename T, typename F>
cv::Mat make_mat(int rows, int cols, int channels, F f) {
  cv::Mat m(rows, cols, CV_MAKETYPE(cv::DataType<T>::depth, channels));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      for (int k = 0; k < channels; ++k) m.ptr<T>(r)[c * channels + k] = static_cast<T>(f(r, c, k));
  return m;
}

}  // namespace

TEST(Image, ReadsEightBitColourFromOpenCV) {
  TempDir dir;
  const auto bgr =
      make_mat<uchar>(5, 7, 3, [](int r, int c, int k) { return 10 * r + 2 * c + 70 * k; });
  ASSERT_TRUE(cv::imwrite(dir / "c.png", bgr));
  const at::Tensor t = read_image(dir / "c.png");
  ASSERT_EQ(t.sizes(), (at::IntArrayRef{5, 7, 3}));
  EXPECT_EQ(t.scalar_type(), at::kFloat);
  // RGB order: channel 0 is OpenCV's channel 2 (red).
  EXPECT_FLOAT_EQ(t[2][3][0].item<float>(), (10 * 2 + 2 * 3 + 140) / 255.0f);
  EXPECT_FLOAT_EQ(t[2][3][2].item<float>(), (10 * 2 + 2 * 3) / 255.0f);
  // JPEG decodes too (lossy: only the shape and range are checked).
  ASSERT_TRUE(cv::imwrite(dir / "c.jpg", bgr));
  const at::Tensor j = read_image(dir / "c.jpg");
  EXPECT_EQ(j.sizes(), t.sizes());
  EXPECT_TRUE((j >= 0).all().item<bool>() && (j <= 1).all().item<bool>());
}

TEST(Image, ReadsSixteenBitGreyAndRgba) {
  TempDir dir;
  const auto grey = make_mat<ushort>(4, 6, 1, [](int r, int c, int) { return 10000 * r + 7 * c; });
  ASSERT_TRUE(cv::imwrite(dir / "g.png", grey));
  const at::Tensor t = read_image(dir / "g.png");
  ASSERT_EQ(t.sizes(), (at::IntArrayRef{4, 6, 3}));
  EXPECT_FLOAT_EQ(t[3][5][1].item<float>(), 30035 / 65535.0f);
  const at::Tensor raw = read_image_values(dir / "g.png");
  ASSERT_EQ(raw.sizes(), (at::IntArrayRef{4, 6}));
  EXPECT_EQ(raw[3][5].item<float>(), 30035.0f);
  const auto bgra =
      make_mat<uchar>(3, 3, 4, [](int, int c, int k) { return k == 3 ? 0 : 10 * c + k; });
  ASSERT_TRUE(cv::imwrite(dir / "a.png", bgra));
  const at::Tensor rgb = read_image(dir / "a.png");
  ASSERT_EQ(rgb.sizes(), (at::IntArrayRef{3, 3, 3}));
  EXPECT_FLOAT_EQ(rgb[0][2][0].item<float>(),
                  22 / 255.0f);  // alpha 0 is ignored, not premultiplied
  const at::Tensor rgba = read_image_values(dir / "a.png");
  ASSERT_EQ(rgba.sizes(), (at::IntArrayRef{3, 3, 4}));
  EXPECT_EQ(rgba[0][2][0].item<float>(), 22.0f);
  // A 2x2 grey+alpha PNG (colour type 4), grey levels 10 20 / 30 40, made by hand.
  const std::string grey_alpha(
      "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x02\x00\x00\x00"
      "\x02\x08\x04\x00\x00\x00\xd8\xbf\xc5\xaf\x00\x00\x00\x12\x49\x44\x41\x54\x78\x9c\x63\xe0\xfa"
      "\x2f\xc2\xc0\x20\xd7\xa0\xf1\x1f\x00\x0c\x2f\x02\xe3\xd2\x7b\x00\x39\x00\x00\x00\x00\x49\x45"
      "\x4e\x44\xae\x42\x60\x82",
      75);
  std::ofstream(dir / "la.png", std::ios::binary) << grey_alpha;
  const at::Tensor la = read_image(dir / "la.png");
  ASSERT_EQ(la.sizes(), (at::IntArrayRef{2, 2, 3}));
  EXPECT_TRUE(at::allclose(la.select(2, 1),
                           at::tensor({10.0f, 20.0f, 30.0f, 40.0f}).view({2, 2}) / 255, 0, 1e-7));
  EXPECT_TRUE(at::equal(la.select(2, 0), la.select(2, 2)));
}

TEST(Image, WriteReadRoundTrips) {
  TempDir dir;
  auto g = at::make_generator<at::CPUGeneratorImpl>(2);
  const at::Tensor rgb8 = at::randint(0, 256, {9, 11, 3}, g, at::kByte);
  write_image_png(dir / "rgb8.png", rgb8);
  EXPECT_TRUE(at::equal(read_image_values(dir / "rgb8.png").to(at::kByte), rgb8));
  // Independent decoder: OpenCV sees the same pixels in BGR order.
  const cv::Mat check = cv::imread(dir / "rgb8.png", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(check.at<cv::Vec3b>(4, 5)[0], rgb8[4][5][2].item<uint8_t>());

  const at::Tensor depth_mm = at::randint(0, 65536, {8, 10}, g, at::kInt);
  write_image_png(dir / "depth.png", depth_mm);
  EXPECT_EQ(cv::imread(dir / "depth.png", cv::IMREAD_UNCHANGED).depth(), CV_16U);
  EXPECT_TRUE(at::equal(read_image_values(dir / "depth.png").to(at::kInt), depth_mm));

  const at::Tensor unit = at::rand({6, 5, 3}, g, at::kDouble);
  write_image_png(dir / "f8.png", unit);
  EXPECT_LE((read_image(dir / "f8.png").to(at::kDouble) - unit).abs().max().item<double>(),
            0.5 / 255 + 1e-7);
  write_image_png(dir / "f16.png", unit, 16);
  EXPECT_LE((read_image(dir / "f16.png").to(at::kDouble) - unit).abs().max().item<double>(),
            0.5 / 65535 + 1e-7);

  const at::Tensor rgba = at::randint(0, 256, {4, 4, 4}, g, at::kByte);
  write_image_png(dir / "rgba.png", rgba);
  EXPECT_TRUE(at::equal(read_image_values(dir / "rgba.png").to(at::kByte), rgba));
  EXPECT_TRUE(at::allclose(read_image(dir / "rgba.png"), rgba.narrow(2, 0, 3).to(at::kFloat) / 255,
                           0, 1e-7));

  const at::Tensor mask = at::rand({5, 5}, g) > 0.5;
  write_image_png(dir / "mask.png", mask);
  EXPECT_TRUE(at::equal(read_image_values(dir / "mask.png"), mask.to(at::kFloat) * 255));
}

TEST(Image, CorruptAndMissingFiles) {
  TempDir dir;
  EXPECT_THROW(read_image(dir / "missing.png"), std::runtime_error);
  std::ofstream(dir / "junk.png") << "this is not an image";
  try {
    read_image(dir / "junk.png");
    FAIL() << "no error for a corrupt file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("junk.png"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("cannot decode"), std::string::npos);
  }
  // A PNG cut in half.
  write_image_png(dir / "whole.png", at::randint(0, 256, {64, 64, 3}, at::kByte));
  std::ifstream in(dir / "whole.png", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir / "half.png", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_THROW(read_image(dir / "half.png"), std::runtime_error);
  { std::ofstream empty(dir / "empty.png"); }
  EXPECT_THROW(read_image(dir / "empty.png"), std::runtime_error);
}

TEST(Image, WriterRejectsBadInputs) {
  TempDir dir;
  const auto path = dir / "bad.png";
  EXPECT_THROW(write_image_png(path, at::zeros({2, 2, 2})), std::invalid_argument);
  EXPECT_THROW(write_image_png(path, at::zeros({2})), std::invalid_argument);
  EXPECT_THROW(write_image_png(path, at::full({2, 2}, NAN)), std::invalid_argument);
  EXPECT_THROW(write_image_png(path, at::full({2, 2}, 70000, at::kInt)), std::invalid_argument);
  EXPECT_THROW(write_image_png(path, at::zeros({2, 2}), 12), std::invalid_argument);
  EXPECT_THROW(write_image_png(path, at::zeros({0, 2})), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));
}

#else

TEST(Image, BuiltWithoutImageIOSaysSo) {
  TempDir dir;
  EXPECT_FALSE(image_io_available());
  try {
    read_image(dir / "x.png");
    FAIL() << "no error without OpenCV";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("built without image I/O"), std::string::npos);
  }
  EXPECT_THROW(write_image_png(dir / "x.png", at::zeros({2, 2})), std::runtime_error);
  EXPECT_THROW(read_image_values(dir / "x.png"), std::runtime_error);
}

#endif
