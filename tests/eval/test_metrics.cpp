// Closed-form cases of the metric protocol, entry selection, degenerate inputs, averaging.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "omnipoint/eval/metrics.h"

using namespace omnipoint::eval;

namespace {

// A smooth synthetic scene: depth in [2, 6], points by a pinhole unprojection.
GroundTruth scene(bool metric, int64_t height = 50, int64_t width = 70) {
  const at::Tensor v = at::linspace(-1, 1, height, at::kFloat).view({-1, 1});
  const at::Tensor u = at::linspace(-1, 1, width, at::kFloat).view({1, -1});
  GroundTruth gt;
  gt.depth = 4 + 1.5 * at::sin(2 * u) * at::cos(3 * v) + 0.3 * u;
  gt.points = at::stack({u * gt.depth * 0.8, v * gt.depth * 0.6, gt.depth}, -1);
  gt.mask = (u * u + v * v < 1.6).expand({height, width}).contiguous();
  gt.is_metric = metric;
  return gt;
}

Prediction predict(const at::Tensor& depth, const at::Tensor& points, bool metric) {
  Prediction p;
  p.depth = depth;
  p.points = points;
  p.is_metric = metric;
  return p;
}

bool has_warning(const Metrics& m, const std::string& fragment) {
  for (const auto& w : m.warnings)
    if (w.find(fragment) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST(Metrics, PerfectPredictionScoresZeroAndOne) {
  const GroundTruth gt = scene(true);
  const Metrics m = compute_metrics(predict(gt.depth, gt.points, true), gt);
  ASSERT_EQ(m.entries.size(), kMetricEntries.size());
  for (const char* name : kMetricEntries) {
    SCOPED_TRACE(name);
    EXPECT_NEAR(m.entries.at(name).rel, 0.0, 1e-5);
    EXPECT_EQ(m.entries.at(name).delta1, 1.0);
  }
  EXPECT_TRUE(m.warnings.empty());
  EXPECT_EQ(m.num_valid_pixels, gt.mask.sum().item<int64_t>());
}

TEST(Metrics, ScaleErrorIsRemovedByScaleInvariantAlignment) {
  const GroundTruth gt = scene(false);
  const Metrics m = compute_metrics(predict(0.37 * gt.depth, 0.37 * gt.points, false), gt);
  EXPECT_EQ(m.entries.count("depth_metric"), 0u);
  EXPECT_EQ(m.entries.count("points_metric"), 0u);
  for (const char* name :
       {"depth_scale_invariant", "depth_affine_invariant", "disparity_affine_invariant",
        "points_scale_invariant", "points_affine_invariant"}) {
    SCOPED_TRACE(name);
    EXPECT_NEAR(m.entries.at(name).rel, 0.0, 1e-5);
    EXPECT_EQ(m.entries.at(name).delta1, 1.0);
  }
  EXPECT_NEAR(m.alignment.at("depth_scale_invariant").scale, 1 / 0.37, 1e-5);
}

TEST(Metrics, ShiftIsRemovedByAffineAlignmentOnly) {
  const GroundTruth gt = scene(true);
  const at::Tensor offset = at::tensor({0.4f, -0.2f, 1.5f});
  const Metrics m = compute_metrics(predict(gt.depth + 1.5, gt.points + offset, true), gt);
  EXPECT_NEAR(m.entries.at("depth_affine_invariant").rel, 0.0, 1e-5);
  EXPECT_NEAR(m.alignment.at("depth_affine_invariant").shift.at(0), -1.5, 1e-5);
  EXPECT_NEAR(m.entries.at("points_affine_invariant").rel, 0.0, 1e-5);
  EXPECT_NEAR(m.entries.at("points_metric").rel, 0.0, 1e-5);  // a pure translation
  EXPECT_GT(m.entries.at("depth_scale_invariant").rel, 1e-2);
  EXPECT_GT(m.entries.at("depth_metric").rel, 1e-1);
  EXPECT_GT(m.entries.at("points_scale_invariant").rel, 1e-2);
}

TEST(Metrics, PointEntriesOnlyWithPoints) {
  const GroundTruth gt = scene(true);
  const Metrics m = compute_metrics(predict(gt.depth, at::Tensor(), true), gt);
  EXPECT_EQ(m.entries.size(), 4u);
  EXPECT_EQ(m.entries.count("points_scale_invariant"), 0u);
}

TEST(Metrics, EmptyMaskGivesNaNWithWarnings) {
  GroundTruth gt = scene(true);
  gt.mask = at::zeros_like(gt.mask);
  const Metrics m = compute_metrics(predict(gt.depth, gt.points, true), gt);
  ASSERT_EQ(m.entries.size(), kMetricEntries.size());
  for (const auto& entry : m.entries) EXPECT_TRUE(std::isnan(entry.second.rel)) << entry.first;
  EXPECT_TRUE(has_warning(m, "no valid pixel"));
  EXPECT_EQ(m.num_lowres_samples, 0);
}

TEST(Metrics, NonFinitePredictionGivesNaNForItsEntries) {
  const GroundTruth gt = scene(true);
  at::Tensor depth = gt.depth.clone();
  depth[25][35] = std::nanf("");
  at::Tensor points = gt.points.clone();
  points[25][35][1] = INFINITY;
  const Metrics m = compute_metrics(predict(depth, points, true), gt);
  for (const char* name : kMetricEntries)
    EXPECT_TRUE(std::isnan(m.entries.at(name).delta1)) << name;
  EXPECT_TRUE(has_warning(m, "predicted depth has NaN/inf"));
  EXPECT_TRUE(has_warning(m, "predicted points have NaN/inf"));
}

TEST(Metrics, ConstantAndZeroPredictions) {
  const GroundTruth gt = scene(false);
  const Metrics constant =
      compute_metrics(predict(at::full_like(gt.depth, 3.0), at::Tensor(), false), gt);
  EXPECT_TRUE(std::isnan(constant.entries.at("disparity_affine_invariant").rel));
  EXPECT_TRUE(has_warning(constant, "disparity_affine_invariant"));
  EXPECT_TRUE(std::isfinite(constant.entries.at("depth_scale_invariant").rel));
  EXPECT_TRUE(std::isnan(constant.entries.at("depth_affine_invariant").rel));  // scale undetermined

  const Metrics zeros =
      compute_metrics(predict(at::zeros_like(gt.depth), at::zeros_like(gt.points), false), gt);
  for (const auto& entry : zeros.entries) EXPECT_TRUE(std::isnan(entry.second.rel)) << entry.first;
  EXPECT_TRUE(has_warning(zeros, "depth_scale_invariant"));
  EXPECT_TRUE(has_warning(zeros, "points_scale_invariant"));
}

TEST(Metrics, NonPositiveAlignedDepthIsReported) {
  const GroundTruth gt = scene(true);
  at::Tensor depth = gt.depth.clone();
  depth[25][35] = -1.0f;
  const Metrics m = compute_metrics(predict(depth, at::Tensor(), true), gt);
  EXPECT_TRUE(has_warning(m, "depth_metric: 1 aligned depths are <= 0"));
  EXPECT_TRUE(std::isfinite(m.entries.at("depth_metric").delta1));
}

TEST(Metrics, InvalidGroundTruthInsideMaskGivesNaN) {
  GroundTruth gt = scene(true);
  gt.depth = gt.depth.clone();
  gt.depth[25][35] = 0.0f;
  const Metrics m = compute_metrics(predict(gt.depth, gt.points, true), gt);
  EXPECT_TRUE(std::isnan(m.entries.at("depth_metric").rel));
  EXPECT_TRUE(has_warning(m, "ground-truth depth"));
  EXPECT_TRUE(std::isfinite(m.entries.at("points_metric").rel));
}

TEST(Metrics, RejectsMismatchedShapes) {
  const GroundTruth gt = scene(true);
  EXPECT_THROW(compute_metrics(predict(gt.depth.t(), at::Tensor(), true), gt),
               std::invalid_argument);
  EXPECT_THROW(compute_metrics(predict(gt.depth, gt.depth, true), gt), std::invalid_argument);
  GroundTruth bad = gt;
  bad.mask = gt.mask.to(at::kByte);
  EXPECT_THROW(compute_metrics(predict(gt.depth, at::Tensor(), true), bad), std::invalid_argument);
}

TEST(Metrics, Float64MatchesFloat32) {
  const GroundTruth gt = scene(true);
  GroundTruth gt64 = gt;
  gt64.depth = gt.depth.to(at::kDouble);
  gt64.points = gt.points.to(at::kDouble);
  const at::Tensor depth = 0.8 * gt.depth + 0.3 * at::sin(5 * gt.depth);
  const Metrics m32 = compute_metrics(predict(depth, gt.points * 1.1, true), gt);
  const Metrics m64 =
      compute_metrics(predict(depth.to(at::kDouble), gt64.points * 1.1, true), gt64);
  for (const char* name : kMetricEntries)
    EXPECT_NEAR(m32.entries.at(name).rel, m64.entries.at(name).rel, 1e-5) << name;
}

TEST(Subsample, UpsamplingStaysInsideTheImageAndOnValidPixels) {
  const at::Tensor mask = at::rand({30, 200}) < 0.5;
  const Subsample sub = mask_aware_subsample(mask);
  ASSERT_EQ(sub.index.sizes(), at::IntArrayRef({2, 64, 64}));
  const at::Tensor rows = sub.index[0].masked_select(sub.mask),
                   cols = sub.index[1].masked_select(sub.mask);
  EXPECT_TRUE((rows < 30).all().item<bool>());
  EXPECT_TRUE((cols < 200).all().item<bool>());
  EXPECT_TRUE(mask.index({rows, cols}).all().item<bool>());
  EXPECT_TRUE(mask_aware_subsample(at::ones({64, 64}, at::kBool)).mask.all().item<bool>());
}

TEST(Average, SkipsMissingEntriesAndCountsNaN) {
  Metrics a, b, c;
  a.entries["depth_metric"] = {0.2, 0.8};
  a.entries["depth_scale_invariant"] = {0.1, 0.9};
  b.entries["depth_scale_invariant"] = {0.3, 0.7};
  c.entries["depth_scale_invariant"] = {std::nan(""), std::nan("")};
  const auto mean = average_metrics({a, b, c});
  EXPECT_DOUBLE_EQ(mean.at("depth_metric").rel, 0.2);
  EXPECT_EQ(mean.at("depth_metric").count, 1);
  EXPECT_DOUBLE_EQ(mean.at("depth_scale_invariant").rel, 0.2);
  EXPECT_DOUBLE_EQ(mean.at("depth_scale_invariant").delta1, 0.8);
  EXPECT_EQ(mean.at("depth_scale_invariant").count, 2);
  EXPECT_EQ(mean.at("depth_scale_invariant").excluded, 1);
}
