// The properties every camera model must have, checked for the sample camera of each model
// (sample_cameras.h) in float32 and float64.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "camera/sample_cameras.h"
#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {
namespace {

struct Precision {
  at::ScalarType dtype;
  double pixel_tolerance;  // pixel -> ray -> pixel, px
  double ray_tolerance;    // ray -> pixel -> ray, |difference|
};

const Precision kFloat32{at::kFloat, 1e-3, 1e-5};
const Precision kFloat64{at::kDouble, 1e-6, 1e-9};

class CameraModelTest : public ::testing::TestWithParam<std::string> {
 protected:
  Camera camera() const { return parse_camera(GetParam()); }
};

std::string test_name(const ::testing::TestParamInfo<std::string>& info) {
  return info.param.substr(0, info.param.find(' ')) + "_" + std::to_string(info.index);
}

// Random directions over the whole sphere (fixed seed).
at::Tensor random_directions(int64_t count, at::ScalarType dtype) {
  at::manual_seed(7);
  const auto directions = at::randn({count, 3}, at::TensorOptions().dtype(at::kDouble));
  return (directions / directions.norm(2, -1, true)).to(dtype);
}

void check_pixel_ray_pixel(const Camera& camera, const Precision& precision) {
  const auto options = at::TensorOptions().dtype(precision.dtype);
  const auto map = camera.ray_map(options);
  ASSERT_EQ(map.rays.sizes(), (std::vector<int64_t>{camera.height(), camera.width(), 3}));
  ASSERT_EQ(map.valid.sizes(), (std::vector<int64_t>{camera.height(), camera.width()}));
  ASSERT_EQ(map.rays.scalar_type(), precision.dtype);
  ASSERT_GT(map.valid.sum().item<int64_t>(), 0) << "no valid pixel";

  const auto projected = camera.project(map.rays);
  const auto both = map.valid & projected.valid;
  EXPECT_TRUE(at::equal(both, map.valid)) << "a valid ray does not project back";
  const auto error = (projected.pixels - camera.pixel_centres(options)).norm(2, -1);
  const double max_error = at::where(both, error, at::zeros_like(error)).max().item<double>();
  EXPECT_LE(max_error, precision.pixel_tolerance) << camera.to_spec();
}

void check_ray_pixel_ray(const Camera& camera, const Precision& precision) {
  const auto directions = random_directions(20000, precision.dtype);
  const auto projected = camera.project(directions);
  ASSERT_FALSE(at::isnan(projected.pixels).any().item<bool>());
  const auto in_view = projected.valid & camera.inside_image(projected.pixels);
  ASSERT_GT(in_view.sum().item<int64_t>(), 0);
  const auto back = camera.unproject(projected.pixels);
  EXPECT_TRUE(at::equal(back.valid & in_view, in_view)) << "a projected ray does not unproject";
  const auto error = (back.rays - directions).norm(2, -1);
  const double max_error = at::where(in_view, error, at::zeros_like(error)).max().item<double>();
  EXPECT_LE(max_error, precision.ray_tolerance) << camera.to_spec();
}

void check_unit_rays_and_invalid_zero(const Camera& camera, at::ScalarType dtype) {
  // Pixels well beyond the image too, where models may be undefined.
  const auto options = at::TensorOptions().dtype(dtype);
  const auto xs = at::linspace(-2.0 * camera.width(), 3.0 * camera.width(), 101, options);
  const auto ys = at::linspace(-2.0 * camera.height(), 3.0 * camera.height(), 77, options);
  const auto grid = at::stack(at::meshgrid({xs, ys}, "xy"), -1);
  for (const auto& rays : {camera.ray_map(options), camera.unproject(grid)}) {
    ASSERT_FALSE(at::isnan(rays.rays).any().item<bool>());
    const auto norms = rays.rays.norm(2, -1);
    const auto valid_norm_error = at::where(rays.valid, (norms - 1).abs(), at::zeros_like(norms));
    EXPECT_LE(valid_norm_error.max().item<double>(), dtype == at::kFloat ? 1e-6 : 1e-12);
    EXPECT_EQ(at::where(rays.valid, at::zeros_like(norms), norms).max().item<double>(), 0.0)
        << "invalid rays must be zero";
  }
  // Projection of odd points: the origin, behind the camera, far off-axis.
  const auto points =
      at::tensor({0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 1.0, 2.0, -3.0, 1e6, 0.0, 1e-9, 0.3, -0.2, 1.0},
                 options)
          .view({-1, 3});
  const auto projected = camera.project(points);
  ASSERT_FALSE(at::isnan(projected.pixels).any().item<bool>());
  EXPECT_FALSE(projected.valid[0].item<bool>()) << "the origin has no direction";
  const auto invalid_pixels =
      at::where(projected.valid.unsqueeze(-1), at::zeros_like(projected.pixels), projected.pixels);
  EXPECT_EQ(invalid_pixels.abs().max().item<double>(), 0.0) << "invalid pixels must be zero";
}

// (Each TEST_P covers both precisions: every test is a process, and LibTorch takes a while to load.)
TEST_P(CameraModelTest, PixelRayPixel) {
  check_pixel_ray_pixel(camera(), kFloat32);
  check_pixel_ray_pixel(camera(), kFloat64);
}
TEST_P(CameraModelTest, RayPixelRay) {
  check_ray_pixel_ray(camera(), kFloat32);
  check_ray_pixel_ray(camera(), kFloat64);
}
TEST_P(CameraModelTest, UnitRaysAndZeroWhereInvalid) {
  check_unit_rays_and_invalid_zero(camera(), at::kFloat);
  check_unit_rays_and_invalid_zero(camera(), at::kDouble);
}

TEST_P(CameraModelTest, SpecJsonAndBatchShapes) {
  const auto original = camera();
  EXPECT_EQ(parse_camera(original.to_spec()), original);
  EXPECT_EQ(parse_camera(original.to_json()), original);

  const auto& cam = original;
  const auto pixels =
      cam.pixel_centres(at::kDouble).narrow(0, 0, 4).narrow(1, 0, 6).reshape({2, 2, 6, 2});
  const auto rays = cam.unproject(pixels);
  EXPECT_EQ(rays.rays.sizes(), (std::vector<int64_t>{2, 2, 6, 3}));
  EXPECT_EQ(rays.valid.sizes(), (std::vector<int64_t>{2, 2, 6}));
  const auto pixels_back = cam.project(rays.rays);
  EXPECT_EQ(pixels_back.pixels.sizes(), (std::vector<int64_t>{2, 2, 6, 2}));
}

INSTANTIATE_TEST_SUITE_P(AllModels, CameraModelTest,
                         ::testing::ValuesIn(testing::sample_camera_specs()), test_name);

// The typed tests above reach a model only through its sample: a registered model without one
// (step 3 of "How to add a model", camera_model.h) would go untested.
TEST(CameraModels, EveryRegisteredModelHasASampleCamera) {
  std::set<std::string> sampled;
  for (const std::string& spec : testing::sample_camera_specs())
    sampled.insert(parse_camera(spec).model_name());
  for (const std::string& name : camera_model_names())
    EXPECT_EQ(sampled.count(name), 1U) << name << " has no sample in sample_cameras.h";
}

}  // namespace
}  // namespace omnipoint::camera
