// Resizing and cropping a camera: a pixel of the new image sees the same ray as the
// corresponding pixel of the original, for every model.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include "camera/sample_cameras.h"
#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {
namespace {

// Max |ray difference| where both are valid; also requires the validity masks to agree away
// from the edge of the domain (compared only where both are valid).
double max_ray_difference(const Rays& a, const Rays& b) {
  const auto both = a.valid & b.valid;
  EXPECT_GT(both.sum().item<int64_t>(), 0);
  const auto difference = (a.rays - b.rays).abs();
  return at::where(both.unsqueeze(-1), difference, at::zeros_like(difference)).max().item<double>();
}

class ResizeCropTest : public ::testing::TestWithParam<std::string> {};

void expect_resized_sees_the_same_rays(const Camera& camera) {
  // Uniform resize by 3/4 (sizes of the samples are multiples of 4).
  const auto resized = camera.resized(camera.width() * 3 / 4, camera.height() * 3 / 4);
  const auto pixels = resized.pixel_centres(at::kDouble);
  const double sx = static_cast<double>(resized.width()) / camera.width();
  const double sy = static_cast<double>(resized.height()) / camera.height();
  const auto original = pixels / at::tensor({sx, sy}, at::kDouble);
  EXPECT_LE(max_ray_difference(resized.unproject(pixels), camera.unproject(original)), 1e-9);
}

void expect_cropped_sees_the_same_rays(const Camera& camera) {
  const int64_t x0 = camera.width() / 5, y0 = camera.height() / 7;
  const auto cropped = camera.cropped(x0, y0, camera.width() / 2, camera.height() / 3);
  EXPECT_EQ(cropped.width(), camera.width() / 2);
  const auto pixels = cropped.pixel_centres(at::kDouble);
  const auto original = pixels + at::tensor({double(x0), double(y0)}, at::kDouble);
  EXPECT_LE(max_ray_difference(cropped.unproject(pixels), camera.unproject(original)), 1e-9);
}

// Both in one test: every test is a process, and LibTorch takes a while to load.
TEST_P(ResizeCropTest, SeeTheSameRays) {
  const auto camera = parse_camera(GetParam());
  expect_resized_sees_the_same_rays(camera);
  expect_cropped_sees_the_same_rays(camera);
}

INSTANTIATE_TEST_SUITE_P(AllModels, ResizeCropTest,
                         ::testing::ValuesIn(testing::sample_camera_specs()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return info.param.substr(0, info.param.find(' ')) + "_" +
                                  std::to_string(info.index);
                         });

TEST(ResizeCrop, NonUniformResizeOfTwoFocalModel) {
  const auto camera = parse_camera("OPENCV 640 480 500 505 320.5 240.5 -0.1 0.01 0.001 0.002");
  const auto resized = camera.resized(320, 360);
  EXPECT_EQ(resized.params()[0], 250);
  EXPECT_EQ(resized.params()[1], 505 * 0.75);
  EXPECT_EQ(resized.params()[2], 160.25);
  EXPECT_EQ(resized.params()[4], -0.1);
}

TEST(ResizeCrop, RejectsEmptySizes) {
  const auto camera = parse_camera("PINHOLE 64 48 50 50 32 24");
  EXPECT_THROW(camera.resized(0, 10), std::invalid_argument);
  EXPECT_THROW(camera.cropped(0, 0, 10, -1), std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::camera
