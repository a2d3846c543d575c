// Perspective-to-Any against the synthetic renderer: a pinhole render turned into a panorama
// must agree with the renderer's own panorama of the same scene and pose, and a translated
// virtual camera must never see a background surface through a foreground object.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "omnipoint/augment/p2a.h"
#include "omnipoint/augment/virtual_camera.h"
#include "omnipoint/augment/warp.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/data/synth/synthesize.h"
#include "support/fast_synth.h"
#include "support/thread_count.h"

namespace omnipoint::augment {
namespace {
using data::synth::SceneKind;

// Distances of valid pixels agree with the ground truth within 2 % everywhere: the read-back
// interpolates bilinearly between source pixel centres that agree within the 5 % tolerance,
// so a small step (a skirting board, a picture on a wall) inside one source pixel quad is
// smoothed; 99 % of the pixels agree within 1 % (grazing ground far away is the worst case).
constexpr double kRelativeTolerance = 0.02;
constexpr double kTypicalTolerance = 0.01;

double quantile_of(const at::Tensor& values, double q) {
  return values.to(at::kDouble).quantile(q).item<double>();
}

TEST(PerspectiveToAny, PinholeToPanoramaMatchesTheRenderersPanorama) {
  const auto pinhole = camera::centred_pinhole(90, 160, 120);
  const camera::Camera pano("EQUIRECTANGULAR", 256, 128, {});
  const auto source = data::synth::synthesize(SceneKind::kIndoor, 7, pinhole, test::fast_synth());
  const auto truth = data::synth::synthesize(SceneKind::kIndoor, 7, pano, test::fast_synth());
  const auto out = perspective_to_any(pinhole, source.sample.image, source.sample.distance,
                                      source.sample.mask, {pano, {}, {}});
  EXPECT_EQ(out.camera, pano);
  EXPECT_TRUE(at::allclose(out.rays, pano.ray_map(at::kFloat).rays));

  // Pixels the pinhole could not see are invalid.
  const auto seen = pinhole.project(pano.ray_map(at::kDouble).rays);
  const auto visible = seen.valid & pinhole.inside_image(seen.pixels);
  EXPECT_EQ((out.mask & visible.logical_not()).sum().item<int64_t>(), 0);
  // Almost everything it saw that has geometry is labelled.
  const auto labelled_share =
      (out.mask.sum().item<double>() / (visible & truth.sample.mask).sum().item<double>());
  EXPECT_GT(labelled_share, 0.85);

  // Every valid pixel agrees with the renderer.
  ASSERT_TRUE((out.mask & truth.sample.mask.logical_not()).sum().item<int64_t>() == 0);
  const auto d = out.distance.masked_select(out.mask),
             g = truth.sample.distance.masked_select(out.mask);
  EXPECT_LE(((d - g).abs() / g).max().item<double>(), kRelativeTolerance);
  EXPECT_LE(quantile_of((d - g).abs() / g, 0.99), kTypicalTolerance);
  // Colours come from the same surface (textures differ only below the pixel scale).
  const auto colour_error =
      (out.image - truth.sample.image).abs().mean(-1).masked_select(out.mask).mean();
  EXPECT_LT(colour_error.item<double>(), 0.06);
  EXPECT_EQ(
      out.distance.masked_select((out.mask | out.filled).logical_not()).abs().sum().item<double>(),
      0.0);
  EXPECT_EQ((out.mask & out.filled).sum().item<int64_t>(), 0);
}

TEST(PerspectiveToAny, RotatedFisheyeMatchesTheRendererThroughTheSameRotation) {
  const auto pinhole = camera::centred_pinhole(100, 160, 120);
  const auto fisheye = fisheye_with_fov("DOUBLE_SPHERE", 128, 128, 200, {-0.1, 0.6});
  const auto source = data::synth::synthesize(SceneKind::kOutdoor, 3, pinhole, test::fast_synth());
  const at::Tensor rotation = rotation_from_angles(20, -10, 5);
  const auto out = perspective_to_any(pinhole, source.sample.image, source.sample.distance,
                                      source.sample.mask, {fisheye, rotation, {}});
  // The renderer, given the fisheye's rays turned into the source frame.
  const auto rays = fisheye.ray_map(at::kDouble);
  const auto truth =
      data::synth::render_scene(source.scene, rays.rays.matmul(rotation.t()), rays.valid);
  ASSERT_GT(out.mask.sum().item<int64_t>(), 1000);
  ASSERT_EQ((out.mask & truth.mask.logical_not()).sum().item<int64_t>(), 0);
  const auto d = out.distance.masked_select(out.mask).to(at::kDouble),
             g = truth.distance.masked_select(out.mask);
  EXPECT_LE(((d - g).abs() / g).max().item<double>(), kRelativeTolerance);
  EXPECT_LE(quantile_of((d - g).abs() / g, 0.99), kTypicalTolerance);
}

// The z-buffer, the distance sampling and the hole filling are parallel loops: two threads
// must give exactly what one gives. A panorama fine enough, without supersampling, that the
// splats leave holes to fill.
TEST(PerspectiveToAny, TwoThreadsGiveExactlyWhatOneGives) {
  const auto pinhole = camera::centred_pinhole(90, 160, 120);
  const camera::Camera pano("EQUIRECTANGULAR", 1024, 512, {});
  const auto source = data::synth::synthesize(SceneKind::kIndoor, 7, pinhole, test::fast_synth());
  P2AOptions options;
  options.supersample = 1;
  const auto warp = [&](int threads) {
    const test::ThreadCount count(threads);
    return perspective_to_any(pinhole, source.sample.image, source.sample.distance,
                              source.sample.mask, {pano, {}, {}}, options);
  };
  const P2AResult one = warp(1), two = warp(2);
  ASSERT_GT(one.mask.sum().item<int64_t>(), 1000);
  ASSERT_GT(one.filled.sum().item<int64_t>(), 0);
  EXPECT_TRUE(at::equal(two.mask, one.mask));
  EXPECT_TRUE(at::equal(two.filled, one.filled));
  EXPECT_TRUE(at::equal(two.distance, one.distance));
  EXPECT_TRUE(at::equal(two.image, one.image));
}

// A wall 6 m ahead and a box 3 m ahead; the virtual camera moves 0.8 m to the right and
// zooms in (more target pixels than source points on the box: gaps in the splats).
TEST(PerspectiveToAny, ForegroundBoxNeverLetsTheWallThrough) {
  using namespace data::synth;
  Scene scene;
  scene.materials.push_back(Material{Pattern::kChecker, {0.9, 0.2, 0.2}, {0.2, 0.2, 0.9}, 0.5});
  Primitive wall;
  wall.shape = Shape::kPlane;
  wall.center = {0, 6, 0};
  wall.axis = {0, -1, 0};
  Primitive box;
  box.center = {0.2, 3, 1.5};
  box.half_size = {0.4, 0.4, 0.4};
  scene.primitives = {wall, box};
  scene.pose = make_pose({0, 0, 1.5}, 0, 0, 0);
  const auto source_camera = camera::centred_pinhole(70, 120, 90);
  const auto source_rays = source_camera.ray_map(at::kDouble);
  const auto source = render_scene(scene, source_rays.rays, source_rays.valid);
  const at::Tensor image = source.image.to(at::kFloat) / 255.0;

  const auto target_camera = camera::centred_pinhole(40, 160, 120);
  const at::Tensor centre = at::tensor({0.8, 0.0, 0.0}, at::kDouble);
  P2AOptions options;
  options.supersample = 1;  // provoke gaps
  const auto out = perspective_to_any(source_camera, image, source.distance.to(at::kFloat),
                                      source.mask, {target_camera, {}, centre}, options);
  // Ground truth from the moved camera (level pose: camera x is world x).
  Scene moved = scene;
  moved.pose = make_pose({0.8, 0, 1.5}, 0, 0, 0);
  const auto target_rays = target_camera.ray_map(at::kDouble);
  const auto truth = render_scene(moved, target_rays.rays, target_rays.valid);
  const auto box_pixels = truth.mask & (truth.distance < 4.0);
  ASSERT_GT((out.mask & box_pixels).sum().item<int64_t>(), 500);
  // Where the truth is the box, a valid pixel is never the wall.
  EXPECT_EQ((out.mask & box_pixels & (out.distance > 4.0)).sum().item<int64_t>(), 0);
  const auto d = out.distance.masked_select(out.mask).to(at::kDouble),
             g = truth.distance.masked_select(out.mask);
  EXPECT_LE(((d - g).abs() / g).max().item<double>(), 0.02);
  // The wall behind the box that only the moved camera sees (disoccluded) is not labelled.
  const auto wall_pixels = truth.mask & (truth.distance > 4.0);
  const auto back = centre.view({1, 1, 3}) + target_rays.rays * truth.distance.unsqueeze(-1);
  const auto in_source = source_camera.project(back);
  const auto seen_distance =
      source.distance.index({in_source.pixels.select(-1, 1).floor().clamp(0, 89).to(at::kLong),
                             in_source.pixels.select(-1, 0).floor().clamp(0, 119).to(at::kLong)});
  const auto hidden_wall =
      wall_pixels & (seen_distance < 4.0) & source_camera.inside_image(in_source.pixels);
  ASSERT_GT(hidden_wall.sum().item<int64_t>(), 100);
  EXPECT_EQ((out.mask & hidden_wall).sum().item<int64_t>(), 0);
}

TEST(PerspectiveToAny, BadInputsAreRejected) {
  const auto cam = camera::centred_pinhole(60, 8, 6);
  const VirtualView target{camera::Camera("EQUIRECTANGULAR", 16, 8, {}), {}, {}};
  const auto image = at::zeros({6, 8, 3}), distance = at::ones({6, 8});
  const auto mask = at::ones({6, 8}, at::kBool);
  EXPECT_THROW(perspective_to_any(cam, at::zeros({6, 7, 3}), distance, mask, target),
               std::invalid_argument);
  EXPECT_THROW(perspective_to_any(cam, image, distance, mask.to(at::kFloat), target),
               std::invalid_argument);
  EXPECT_THROW(perspective_to_any(cam, image, at::ones({8, 6}), mask, target),
               std::invalid_argument);
  EXPECT_THROW(perspective_to_any(cam, image, distance, mask, {target.camera, at::eye(4), {}}),
               std::invalid_argument);
  P2AOptions bad;
  bad.supersample = -1;
  EXPECT_THROW(perspective_to_any(cam, image, distance, mask, target, bad), std::invalid_argument);
}

TEST(VirtualCameras, SampledFisheyesSpanTheirFieldOfViewAndEveryKindOccurs) {
  VirtualCameraDistribution distribution;
  distribution.fisheye_size = 64;
  distribution.panorama_width = 64;
  auto generator = at::make_generator<at::CPUGeneratorImpl>(11);
  std::set<std::string> models;
  int cropped = 0;
  for (int i = 0; i < 60; ++i) {
    const VirtualView view = sample_virtual_view(distribution, generator);
    models.insert(view.camera.model_name());
    if (view.camera.model_name() == "EQUIRECTANGULAR" && !view.camera.params().empty()) ++cropped;
    // A proper rotation.
    EXPECT_TRUE(at::allclose(view.rotation.matmul(view.rotation.t()), at::eye(3, at::kDouble),
                             1e-12, 1e-12));
  }
  EXPECT_EQ(models.size(), 5u);
  EXPECT_GT(cropped, 0);
  for (const char* model : {"OPENCV_FISHEYE", "MEI", "EUCM", "DOUBLE_SPHERE"}) {
    const std::vector<double> shape =
        std::string(model) == "OPENCV_FISHEYE" ? std::vector<double>{0.01, 0, 0, 0}
        : std::string(model) == "MEI"          ? std::vector<double>{1.0, 0.01, 0, 0, 0}
        : std::string(model) == "EUCM"         ? std::vector<double>{0.6, 1.0}
                                               : std::vector<double>{-0.1, 0.6};
    const auto cam = fisheye_with_fov(model, 100, 80, 220, shape);
    const double half = 110 * M_PI / 180;
    const auto rim =
        cam.project(at::tensor({std::sin(half), 0.0, std::cos(half)}, at::kDouble).view({1, 3}));
    EXPECT_TRUE(rim.valid.item<bool>()) << model;
    EXPECT_NEAR(rim.pixels[0][0].item<double>(), 50 + 40, 1e-6) << model;
  }
  EXPECT_THROW(fisheye_with_fov("DOUBLE_SPHERE", 64, 64, 300, {-0.1, 0.6}), std::invalid_argument);
  auto g2 = at::make_generator<at::CPUGeneratorImpl>(3);
  const auto picked = select_items(10000, 0.02, g2);
  const auto count = std::count(picked.begin(), picked.end(), true);
  EXPECT_GT(count, 140);
  EXPECT_LT(count, 260);
}

}  // namespace
}  // namespace omnipoint::augment
