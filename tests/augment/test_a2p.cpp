// Any-to-Perspective with oracle teachers (the renderer's ground truth instead of a network):
// the stitched pseudo-label equals the wide-FoV ground truth inside the view's footprint, and
// the multi-view merge recovers one consistent map from views predicted at different scales.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/augment/virtual_camera.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/data/synth/synthesize.h"
#include "support/fast_synth.h"

namespace omnipoint::augment {
namespace {
using data::synth::SceneKind;

// The renderer as a teacher: the view's rays, turned by the view's rotation into the wide
// camera's frame, are cast into the scene (same centre); `scale` multiplies the distances.
Teacher oracle(const data::synth::Scene& scene, const at::Tensor& rotation, double scale = 1.0) {
  return [scene, rotation, scale](const at::Tensor&, const camera::Camera& cam) {
    const auto rays = cam.ray_map(at::kDouble);
    data::synth::RenderOptions options;
    options.shadows = options.ambient_occlusion = false;
    const auto r =
        data::synth::render_scene(scene, rays.rays.matmul(rotation.t()), rays.valid, options);
    return TeacherPrediction{rays.rays.to(at::kFloat), (r.distance * scale).to(at::kFloat), r.mask};
  };
}

TEST(AnyToPerspective, OracleLabelEqualsTheWideGroundTruthInsideTheFootprint) {
  const std::vector<camera::Camera> wides{
      camera::Camera("EQUIRECTANGULAR", 192, 96, {}),
      fisheye_with_fov("DOUBLE_SPHERE", 128, 128, 200, {-0.1, 0.6})};
  for (const auto& wide : wides) {
    SCOPED_TRACE(wide.to_spec());
    const auto truth = data::synth::synthesize(SceneKind::kIndoor, 5, wide, test::fast_synth());
    const PerspectiveView view = make_perspective_view(70, 30, 10, 96, 80);
    const auto result =
        any_to_perspective(wide, truth.sample.image, view, oracle(truth.scene, view.rotation));
    EXPECT_EQ(result.extracted.image.sizes(), at::IntArrayRef({80, 96, 3}));
    EXPECT_TRUE(result.extracted.valid.all().item<bool>());
    const auto& label = result.label;
    // The footprint: wide pixels whose ray lies inside the view.
    const auto rays = wide.ray_map(at::kDouble);
    const auto in_view = view.camera.project(rays.rays.matmul(view.rotation));
    const auto footprint = rays.valid & in_view.valid & view.camera.inside_image(in_view.pixels) &
                           (rays.rays.matmul(view.rotation).select(-1, 2) > 0);
    EXPECT_EQ((label.mask & footprint.logical_not()).sum().item<int64_t>(), 0);
    EXPECT_GT(label.mask.sum().item<double>(),
              0.9 * (footprint & truth.sample.mask).sum().item<double>());
    ASSERT_EQ((label.mask & truth.sample.mask.logical_not()).sum().item<int64_t>(), 0);
    const auto d = label.distance.masked_select(label.mask),
               g = truth.sample.distance.masked_select(label.mask);
    // Bilinear between view pixels that agree within 5 %: 2 % at worst, 0.5 % for 99 %.
    EXPECT_LE(((d - g).abs() / g).max().item<double>(), 0.02);
    EXPECT_LE(((d - g).abs() / g).to(at::kDouble).quantile(0.99).item<double>(), 0.005);
    EXPECT_EQ(label.distance.masked_select(label.mask.logical_not()).abs().sum().item<double>(),
              0.0);
  }
}

TEST(AnyToPerspective, ExtractedViewIsTheRenderedView) {
  const camera::Camera wide("EQUIRECTANGULAR", 512, 256, {});
  const auto truth = data::synth::synthesize(SceneKind::kOutdoor, 2, wide, test::fast_synth());
  const PerspectiveView view = make_perspective_view(60, -40, 5, 64, 48);
  const auto extracted = extract_view(wide, truth.sample.image, view);
  // The renderer's own pinhole view through the same rotation.
  const auto rays = view.camera.ray_map(at::kDouble);
  const auto rendered =
      data::synth::render_scene(truth.scene, rays.rays.matmul(view.rotation.t()), rays.valid);
  const auto error = (extracted.image - rendered.image.to(at::kFloat) / 255.0).abs().mean();
  EXPECT_LT(error.item<double>(), 0.05);
}

TEST(AnyToPerspective, SampledViewsLookWhereTheWideCameraSees) {
  const auto fisheye = fisheye_with_fov("EUCM", 96, 96, 180, {0.6, 1.0});
  auto generator = at::make_generator<at::CPUGeneratorImpl>(5);
  A2PViewDistribution distribution;
  distribution.min_size = 16;
  distribution.max_size = 32;
  for (int i = 0; i < 20; ++i) {
    const auto view = sample_perspective_view(fisheye, distribution, generator);
    const auto extracted = extract_view(fisheye, at::zeros({96, 96, 3}), view);
    const auto h = view.camera.height(), w = view.camera.width();
    EXPECT_TRUE(extracted.valid[h / 2][w / 2].item<bool>());  // the fisheye sees the view's centre
    EXPECT_LE(std::max(view.camera.width(), view.camera.height()), 32);
  }
}

TEST(AnyToPerspective, MultiViewMergeRecoversOneScaleFromInconsistentViews) {
  const camera::Camera wide("EQUIRECTANGULAR", 128, 64, {});
  const auto truth = data::synth::synthesize(SceneKind::kIndoor, 9, wide, test::fast_synth());
  MultiViewOptions options;
  options.view_size = 64;
  // Each call answers at a different random scale (a perspective model's unknown scale).
  auto generator = at::make_generator<at::CPUGeneratorImpl>(17);
  const Teacher teacher = [&](const at::Tensor& image, const camera::Camera& cam) {
    // Find the view by matching its image (the extraction is deterministic).
    for (const auto& view : tiling_views(wide, options)) {
      if (at::equal(extract_view(wide, truth.sample.image, view).image, image)) {
        const double scale =
            std::exp(at::rand({1}, generator, at::kDouble).item<double>() * 2.0 - 1.0);
        return oracle(truth.scene, view.rotation, scale)(image, cam);
      }
    }
    throw std::logic_error("unknown view");
  };
  const auto merged = predict_wide_from_views(wide, truth.sample.image, teacher, options);
  EXPECT_EQ(merged.view_scales.size(), 18u);
  const auto both = merged.mask & truth.sample.mask;
  // Depth edges and the pixels next to them are not labelled (each view's sampling refuses
  // to interpolate across them), hence 90 % rather than all.
  EXPECT_GT(both.sum().item<double>(), 0.9 * truth.sample.mask.sum().item<double>());
  EXPECT_EQ((merged.mask & truth.sample.mask.logical_not()).sum().item<int64_t>(), 0);
  const auto ratio =
      merged.distance.masked_select(both) / truth.sample.distance.masked_select(both);
  const double median = ratio.median().item<double>();
  // Each view's own interpolation error (<= 2 %, see above) plus blending of neighbours.
  EXPECT_LE((ratio / median - 1).abs().max().item<double>(), 0.03);
  EXPECT_LE((ratio / median - 1).abs().to(at::kDouble).quantile(0.99).item<double>(), 0.01);
}

TEST(AnyToPerspective, BadInputsAreRejected) {
  const camera::Camera wide("EQUIRECTANGULAR", 32, 16, {});
  const auto view = make_perspective_view(60, 0, 0, 8, 8);
  EXPECT_THROW(extract_view(wide, at::zeros({16, 31, 3}), view), std::invalid_argument);
  EXPECT_THROW(extract_view(wide, at::zeros({16, 32, 3}), view, at::ones({16, 32})),
               std::invalid_argument);
  EXPECT_THROW(
      stitch_view(wide, view, TeacherPrediction{{}, at::ones({7, 8}), at::ones({7, 8}, at::kBool)}),
      std::invalid_argument);
  EXPECT_THROW(make_perspective_view(180, 0, 0, 8, 8), std::invalid_argument);
  MultiViewOptions bad;
  bad.fov_deg = 0;
  EXPECT_THROW(tiling_views(wide, bad), std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::augment
