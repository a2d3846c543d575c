// The training objective: each term on a hand-computable case, the perfect prediction, the
// ablation variants, and autograd against central finite differences in double precision.
#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "omnipoint/train/losses.h"

namespace omnipoint::train {
namespace {

const auto kDouble = at::TensorOptions().dtype(at::kDouble);

at::Tensor bools(std::initializer_list<int64_t> values) {
  return at::tensor(values).to(at::kBool);
}

at::Generator generator(uint64_t seed = 1) {
  return at::make_generator<at::CPUGeneratorImpl>(seed);
}

// Unit rays of a centred pinhole camera (B,H,W,3).
at::Tensor pinhole_rays(int64_t batch, int64_t height, int64_t width, double focal) {
  const at::Tensor u = (at::arange(width, kDouble) + 0.5 - width / 2.0) / focal;
  const at::Tensor v = (at::arange(height, kDouble) + 0.5 - height / 2.0) / focal;
  const auto grid = at::meshgrid({v, u}, "ij");
  at::Tensor rays = at::stack({grid[1], grid[0], at::ones_like(grid[0])}, -1);
  rays = rays / rays.norm(2, {-1}, true);
  return rays.unsqueeze(0).expand({batch, height, width, 3}).contiguous();
}

// A ray/distance output with the given maps and a zero-logit mask, metric scale 1.
model::OmniPointOutput make_output(const at::Tensor& rays, const at::Tensor& distance) {
  model::OmniPointOutput out;
  out.ray_raw = rays;
  out.rays = rays;
  out.log_distance = distance.log();
  out.distance = distance;
  out.mask_logits = at::zeros_like(distance);
  out.log_metric_scale = at::zeros({distance.size(0)}, distance.options());
  out.metric_scale = out.log_metric_scale.exp();
  return out;
}

LossTargets make_targets(const at::Tensor& rays, const at::Tensor& distance) {
  LossTargets t;
  t.rays = rays;
  t.distance = distance;
  t.mask = distance > 0;
  t.mask_negative = at::zeros_like(t.mask);
  t.metric = at::ones({distance.size(0)}, at::kBool);
  return t;
}

// A smooth scene: a slanted plane seen by a pinhole camera, distances along the rays.
at::Tensor plane_distance(const at::Tensor& rays) {
  // plane z + 0.3 x = 2  ->  d (r_z + 0.3 r_x) = 2
  return 2.0 / (rays.select(-1, 2) + 0.3 * rays.select(-1, 0));
}

TEST(Losses, PerfectPredictionGivesZeroLoss) {
  const at::Tensor rays = pinhole_rays(2, 24, 24, 20.0);
  const at::Tensor distance = plane_distance(rays);
  model::OmniPointOutput out = make_output(rays, 3.0 * distance);  // scale-invariant: s* = 1/3
  out.log_metric_scale = at::full({2}, std::log(1.0 / 3.0), kDouble);
  LossTargets targets = make_targets(rays, distance);
  targets.mask.index_put_({0, at::indexing::Slice(0, 3)}, false);  // sky rows
  targets.mask_negative = ~targets.mask;
  out.mask_logits =
      at::where(targets.mask, at::full_like(distance, 60.0), at::full_like(distance, -60.0));
  LossConfig config;
  config.local.levels = {4};
  config.local.min_points = 8;
  const Losses losses = compute_losses(out, targets, config, generator());
  EXPECT_TRUE(at::allclose(losses.scale, at::full({2}, 1.0 / 3.0, kDouble), 1e-12, 1e-12));
  for (const auto& [name, term] : losses.terms)
    EXPECT_LT(term.abs().max().item<double>(), 1e-10) << name;
  EXPECT_EQ(losses.terms.size(), 6u);
  EXPECT_LT(losses.total.item<double>(), 1e-10);
}

// align_points: s* from a random subset of the labelled pixels. Exact predictions keep their
// exact scale; a noisy one gets a scale near the all-pixel fit; a subset as large as the image
// changes nothing.
TEST(Losses, ScaleFitOnAPixelSubset) {
  const at::Tensor rays = pinhole_rays(2, 24, 24, 20.0);
  const at::Tensor distance = plane_distance(rays);
  LossTargets targets = make_targets(rays, distance);
  targets.mask.index_put_({0, at::indexing::Slice(0, 3)}, false);
  LossConfig config;
  config.weights = {1, 0, 0, 0, 0, 0};
  LossConfig subset = config;
  subset.align_points = 32;
  EXPECT_TRUE(at::allclose(
      compute_losses(make_output(rays, 3.0 * distance), targets, subset, generator()).scale,
      at::full({2}, 1.0 / 3.0, kDouble), 1e-12, 1e-12));
  const at::Tensor noisy = 3.0 * distance * (1.0 + 0.1 * at::sin(37.0 * distance));
  const at::Tensor all_scale =
      compute_losses(make_output(rays, noisy), targets, config, generator()).scale;
  const at::Tensor subset_scale =
      compute_losses(make_output(rays, noisy), targets, subset, generator()).scale;
  EXPECT_FALSE(at::equal(subset_scale, all_scale));
  EXPECT_TRUE(at::allclose(subset_scale, all_scale, 0.05, 0.0)) << subset_scale << all_scale;
  LossConfig whole = config;
  whole.align_points = int64_t{24} * 24;
  EXPECT_TRUE(at::equal(compute_losses(make_output(rays, noisy), targets, whole, generator()).scale,
                        all_scale));
  subset.point_loss = PointLoss::kDisjoint;
  config.point_loss = PointLoss::kDisjoint;
  EXPECT_TRUE(at::allclose(
      compute_losses(make_output(rays, noisy), targets, subset, generator()).scale,
      compute_losses(make_output(rays, noisy), targets, config, generator()).scale, 0.05, 0.0));
}

TEST(Losses, PointLossHandComputed) {
  // Two pixels on the optical axis at distance 1; predicted 1 and 2. The truncated ROE fit
  // min Σ min(1, |s d̂ − 1|) picks s* = 0.5 (cost 0.5) over s* = 1 (cost 1); the loss is the
  // mean over 2 pixels × 3 coordinates of |0.5·1 − 1| + |0.5·2 − 1| = 0.5 / 6.
  const at::Tensor rays = at::zeros({1, 1, 2, 3}, kDouble).index_fill_(-1, at::tensor({2L}), 1.0);
  const at::Tensor gt = at::ones({1, 1, 2}, kDouble);
  const at::Tensor pred = at::tensor({1.0, 2.0}, kDouble).view({1, 1, 2});
  LossConfig config;
  config.weights = {1, 0, 0, 0, 0, 0};
  const Losses losses =
      compute_losses(make_output(rays, pred), make_targets(rays, gt), config, generator());
  EXPECT_DOUBLE_EQ(losses.scale.item<double>(), 0.5);
  EXPECT_NEAR(losses.terms.at("point").item<double>(), 0.5 / 6.0, 1e-15);
}

TEST(Losses, RayMetricAndMaskHandComputed) {
  const at::Tensor gt_rays = at::tensor({0.0, 0.0, 1.0, 0.6, 0.0, 0.8}, kDouble).view({1, 1, 2, 3});
  const at::Tensor pred_rays =
      at::tensor({0.0, 0.0, 1.0, 0.0, 0.0, 1.0}, kDouble).view({1, 1, 2, 3});
  // |0.6| + |0.2| on one of two pixels.
  EXPECT_NEAR(ray_loss(pred_rays, gt_rays, at::ones({1, 1, 2}, at::kBool)).item<double>(), 0.4,
              1e-15);
  // Invalid camera pixels do not count.
  EXPECT_NEAR(ray_loss(pred_rays, gt_rays, bools({1, 0}).view({1, 1, 2})).item<double>(), 0.0, 0.0);

  const at::Tensor metric = metric_scale_loss(
      at::zeros({3}, kDouble), at::tensor({M_E, M_E, NAN}, kDouble), bools({1, 0, 1}));
  EXPECT_NEAR(metric[0].item<double>(), 1.0, 1e-15);
  EXPECT_EQ(metric[1].item<double>(), 0.0);
  EXPECT_EQ(metric[2].item<double>(), 0.0);

  // Gauge: log-distances {log 2, log 8} on the mask average to log 4 (the unlabelled pixel's
  // 1e6 does not count); an item without labels gives 0.
  const at::Tensor d = at::tensor({2.0, 8.0, 1e6, 5.0, 5.0, 5.0}, kDouble).view({2, 1, 3});
  const at::Tensor gauge = gauge_loss(d, bools({1, 1, 0, 0, 0, 0}).view({2, 1, 3}));
  EXPECT_NEAR(gauge[0].item<double>(), std::pow(std::log(4.0), 2), 1e-14);
  EXPECT_EQ(gauge[1].item<double>(), 0.0);

  // Logit 0 costs log 2 on a positive or negative pixel, nothing on an unknown one.
  const at::Tensor mask =
      mask_loss(at::zeros({1, 1, 4}, kDouble), bools({1, 0, 0, 0}).view({1, 1, 4}),
                bools({0, 1, 0, 0}).view({1, 1, 4}));
  EXPECT_NEAR(mask.item<double>(), 2.0 * std::log(2.0) / 4.0, 1e-15);
}

TEST(Losses, NormalLossHandComputed) {
  // A 2×2 fronto-parallel patch and the same patch tilted by 45° about the y axis: all four
  // triangles are 45° off, Huber-smoothed above β = 3°, divided by 4·max(H, W) = 8.
  const at::Tensor x = at::tensor({0.0, 1.0, 0.0, 1.0}, kDouble).view({1, 2, 2});
  const at::Tensor y = at::tensor({0.0, 0.0, 1.0, 1.0}, kDouble).view({1, 2, 2});
  const at::Tensor gt = at::stack({x, y, at::ones_like(x)}, -1);
  const at::Tensor pred = at::stack({x, y, 1.0 + x}, -1);
  const double beta = 3.0 * M_PI / 180.0;
  const double floor = 0.5 * std::pow(M_PI / 180.0, 2) / beta;  // the 1° clamp's constant, removed
  at::Tensor mask = at::ones({1, 2, 2}, at::kBool);
  EXPECT_NEAR(normal_loss(pred, gt, mask).item<double>(),
              4.0 * (M_PI / 4.0 - 0.5 * beta - floor) / 8.0, 1e-12);
  // One unlabelled corner leaves one triangle (the one opposite to it).
  mask.index_put_({0, 0, 0}, false);
  EXPECT_NEAR(normal_loss(pred, gt, mask).item<double>(), (M_PI / 4.0 - 0.5 * beta - floor) / 8.0,
              1e-12);
  // Scale-invariant, and zero for the same shape.
  EXPECT_NEAR(normal_loss(5.0 * gt, gt, at::ones({1, 2, 2}, at::kBool)).item<double>(), 0.0, 1e-15);
}

TEST(Losses, LocalLossIsAffineInvariantPerPatchAndSeesLocalErrors) {
  const at::Tensor rays = pinhole_rays(1, 32, 32, 30.0);
  const at::Tensor distance = plane_distance(rays);
  const at::Tensor gt = distance.unsqueeze(-1) * rays;
  const at::Tensor mask = at::ones({1, 32, 32}, at::kBool);
  LocalLossOptions options;
  options.min_points = 8;
  const at::Tensor global = at::full({1}, 0.5, kDouble);
  const at::Tensor shifted = 2.0 * gt + at::tensor({0.1, -0.2, 0.3}, kDouble);
  EXPECT_LT(local_loss(shifted, gt, rays, mask, global, 4, options, generator()).item<double>(),
            1e-12);
  // A bump inside the image costs something; a scale far from the global one rejects patches.
  const at::Tensor bumped = 2.0 * gt * (1.0 + 0.2 * at::sin(gt.select(-1, 0) * 9.0).unsqueeze(-1));
  EXPECT_GT(local_loss(bumped, gt, rays, mask, global, 4, options, generator()).item<double>(),
            1e-3);
  EXPECT_EQ(
      local_loss(bumped, gt, rays, mask, at::full({1}, 50.0, kDouble), 4, options, generator())
          .item<double>(),
      0.0);
  // The same generator seed gives the same patches.
  EXPECT_EQ(local_loss(bumped, gt, rays, mask, global, 4, options, generator(3)).item<double>(),
            local_loss(bumped, gt, rays, mask, global, 4, options, generator(3)).item<double>());
}

// Sparse labels (losses.h's rules): every term is finite on an item with 0.5 % of its pixels
// labelled and on one without any label, and so are the gradients; with every pixel labelled a
// sparse item costs what a dense one does, term by term.
TEST(Losses, SparseLabelTermsAreFiniteAndDenseWhenEveryPixelIsLabelled) {
  const int64_t size = 64;
  const at::Tensor rays = pinhole_rays(3, size, size, 50.0);
  const at::Tensor distance = plane_distance(rays);
  // A prediction with local errors, so that every term has something to measure.
  const at::Tensor wobble = 1.0 + 0.2 * at::sin(rays.select(-1, 0) * 23.0);
  const auto output = [&] {
    model::OmniPointOutput out = make_output(rays, (3.0 * distance * wobble).requires_grad_());
    const at::Tensor turned = rays + 0.05 * at::cos(rays * 7.0);
    out.rays = out.ray_raw = turned / turned.norm(2, {-1}, true);
    out.mask_logits = at::full_like(distance, 0.3).requires_grad_();
    out.log_metric_scale = at::full({3}, 0.2, kDouble).requires_grad_();
    return out;
  };
  LossConfig config;
  config.weights.gauge = 0.1;
  config.local.levels = {4, 16};
  config.local.min_points = 8;
  const auto losses_for = [&](const at::Tensor& mask, bool sparse) {
    LossTargets targets = make_targets(rays, at::where(mask, distance, at::zeros_like(distance)));
    targets.mask = mask;
    if (sparse) targets.sparse = at::ones({3}, at::kBool);
    return compute_losses(output(), targets, config, generator(7));
  };

  // Every pixel labelled: the sparse rules give the dense values.
  const at::Tensor full = at::ones({3, size, size}, at::kBool);
  const Losses dense = losses_for(full, false), sparse_full = losses_for(full, true);
  ASSERT_EQ(dense.terms.size(), 7u);
  for (const auto& [name, term] : dense.terms) {
    EXPECT_GT(term.abs().max().item<double>(), 0.0) << name;
    EXPECT_TRUE(at::allclose(sparse_full.terms.at(name), term, 1e-12, 0)) << name;
  }

  // 0.5 % of the pixels (20 of 4096, drawn at random) on the first item, ring-like rows on the
  // second (every 5th row, every 3rd column: labelled neighbours along a row only), none on
  // the third.
  at::Tensor mask = at::zeros({3, size * size}, at::kBool);
  const at::Tensor picks =
      at::randperm(size * size, generator(2), at::TensorOptions().dtype(at::kLong))
          .narrow(0, 0, 20);
  mask[0].index_fill_(0, picks, true);
  mask = mask.view({3, size, size});
  mask[1].index_put_({at::indexing::Slice(0, size, 5), at::indexing::Slice(0, size, 3)}, true);
  mask[1].index_put_({at::indexing::Slice(0, size, 5), at::indexing::Slice(1, size, 3)}, true);
  const Losses sparse = losses_for(mask, true);
  for (const auto& [name, term] : sparse.terms)
    EXPECT_TRUE(at::isfinite(term).all().item<bool>()) << name << ": " << term;
  EXPECT_TRUE(at::isfinite(sparse.total).item<bool>());
  // The point term is the mean over the labelled pixels: H·W / labelled times the dense rule.
  const Losses dense_rule = losses_for(mask, false);
  EXPECT_NEAR(sparse.terms.at("point")[0].item<double>(),
              dense_rule.terms.at("point")[0].item<double>() * size * size / 20.0, 1e-12);
  EXPECT_GT(sparse.terms.at("point")[0].item<double>(), 0.0);
  // A sparse item's patches count like dense ones: more than the dense rule gives them.
  EXPECT_GT(sparse.terms.at("local")[1].item<double>(),
            dense_rule.terms.at("local")[1].item<double>());
  // No labelled triangle on either sparse item: the normal term steps aside.
  EXPECT_EQ(sparse.terms.at("normal")[0].item<double>(), 0.0);
  EXPECT_EQ(sparse.terms.at("normal")[1].item<double>(), 0.0);
  // The unlabelled item: only the camera's rays are left to learn from.
  for (const auto& [name, term] : sparse.terms) {
    if (name != "ray") {
      EXPECT_EQ(term[2].item<double>(), 0.0) << name;
    }
  }
  EXPECT_TRUE(std::isnan(sparse.scale[2].item<double>()));

  // The gradients are finite too (no 0/0 reaches them).
  model::OmniPointOutput out = output();
  LossTargets targets = make_targets(rays, at::where(mask, distance, at::zeros_like(distance)));
  targets.mask = mask;
  targets.sparse = at::ones({3}, at::kBool);
  compute_losses(out, targets, config, generator(7)).total.backward();
  EXPECT_TRUE(at::isfinite(out.distance.grad()).all().item<bool>());
  EXPECT_TRUE(at::isfinite(out.mask_logits.grad()).all().item<bool>());
  EXPECT_TRUE(at::isfinite(out.log_metric_scale.grad()).all().item<bool>());
}

// The normal term of a sparse item is the mean over its labelled cells: a lone labelled 2×2
// cell costs what a fully labelled image of such cells does.
TEST(Losses, SparseNormalTermAveragesOverTheLabelledCells) {
  const at::Tensor x = at::arange(6, kDouble).view({1, 6}).expand({6, 6});
  const at::Tensor y = at::arange(6, kDouble).view({6, 1}).expand({6, 6});
  const at::Tensor gt = at::stack({x, y, at::ones_like(x)}, -1).unsqueeze(0);
  const at::Tensor pred = at::stack({x, y, 1.0 + x}, -1).unsqueeze(0);  // tilted 45°
  const at::Tensor full = at::ones({1, 6, 6}, at::kBool);
  at::Tensor one_cell = at::zeros({1, 6, 6}, at::kBool);
  one_cell.index_put_({0, at::indexing::Slice(2, 4), at::indexing::Slice(2, 4)}, true);
  const at::Tensor sparse = at::ones({1}, at::kBool);
  const double dense_value = normal_loss(pred, gt, full).item<double>();
  EXPECT_GT(dense_value, 0.0);
  EXPECT_NEAR(normal_loss(pred, gt, one_cell, sparse).item<double>(), dense_value, 1e-12);
  // The dense rule averages the one cell over all 25.
  EXPECT_NEAR(normal_loss(pred, gt, one_cell).item<double>(), dense_value / 25.0, 1e-12);
  EXPECT_EQ(normal_loss(pred, gt, at::zeros_like(full), sparse).item<double>(), 0.0);
}

// fit_points: the exact fit on a random subset of each patch. An affine copy of the GT is
// still aligned exactly (any 3 points determine it); on a bumpy prediction the loss moves a
// little from the all-points fit, and a subset at least the window's size changes nothing.
TEST(Losses, LocalLossFitOnAPointSubsetKeepsExactAlignments) {
  const at::Tensor rays = pinhole_rays(2, 32, 32, 30.0);
  const at::Tensor distance = plane_distance(rays);
  const at::Tensor gt = distance.unsqueeze(-1) * rays;
  const at::Tensor mask = at::ones({2, 32, 32}, at::kBool);
  const at::Tensor global = at::full({2}, 0.5, kDouble);
  LocalLossOptions all;
  all.min_points = 8;
  LocalLossOptions subset = all;
  subset.fit_points = 16;
  const at::Tensor shifted = 2.0 * gt + at::tensor({0.1, -0.2, 0.3}, kDouble);
  EXPECT_LT(local_loss(shifted, gt, rays, mask, global, 4, subset, generator())
                .abs()
                .max()
                .item<double>(),
            1e-12);
  const at::Tensor bumped = 2.0 * gt * (1.0 + 0.2 * at::sin(gt.select(-1, 0) * 9.0).unsqueeze(-1));
  // Level 4: windows of 13x13 = 169 points (radius ceil(0.5 / 4 · 45.3)), fitted from 16.
  const double exact =
      local_loss(bumped, gt, rays, mask, global, 4, all, generator()).sum().item<double>();
  const double sampled =
      local_loss(bumped, gt, rays, mask, global, 4, subset, generator()).sum().item<double>();
  EXPECT_NE(sampled, exact);
  EXPECT_NEAR(sampled, exact, 0.3 * exact);
  EXPECT_EQ(
      sampled,
      local_loss(bumped, gt, rays, mask, global, 4, subset, generator()).sum().item<double>());
  LocalLossOptions whole = all;
  whole.fit_points = 169;
  EXPECT_EQ(local_loss(bumped, gt, rays, mask, global, 4, whole, generator()).sum().item<double>(),
            exact);
}

TEST(Losses, DecoupledLossIgnoresRayErrorsNaiveDoesNot) {
  // Correct distances with wrong rays: the decoupled point loss is zero, the naive one is not,
  // and the ray loss carries the whole error.
  const at::Tensor rays = pinhole_rays(1, 8, 8, 6.0);
  const at::Tensor wrong = pinhole_rays(1, 8, 8, 4.0);
  const at::Tensor distance = plane_distance(rays);
  LossConfig config;
  config.weights = {1, 1, 0, 0, 0, 0};
  const model::OmniPointOutput out = make_output(wrong, distance);
  const Losses decoupled = compute_losses(out, make_targets(rays, distance), config, generator());
  EXPECT_LT(decoupled.terms.at("point").item<double>(), 1e-15);
  EXPECT_GT(decoupled.terms.at("ray").item<double>(), 0.01);
  config.point_loss = PointLoss::kNaive;
  EXPECT_GT(compute_losses(out, make_targets(rays, distance), config, generator())
                .terms.at("point")
                .item<double>(),
            1e-3);
  // Disjoint: distances only, so also zero here.
  config.point_loss = PointLoss::kDisjoint;
  EXPECT_LT(compute_losses(out, make_targets(rays, distance), config, generator())
                .terms.at("point")
                .item<double>(),
            1e-15);
  // An XYZ head has no ray term.
  model::OmniPointOutput xyz = out;
  xyz.ray_raw = at::Tensor();
  EXPECT_EQ(
      compute_losses(xyz, make_targets(rays, distance), config, generator()).terms.count("ray"),
      0u);
  EXPECT_THROW(parse_point_loss("entangled"), std::invalid_argument);
}

// Autograd against central differences of f at x (double precision).
void expect_gradient_matches(const std::function<at::Tensor(const at::Tensor&)>& f,
                             const at::Tensor& x0) {
  const at::Tensor x = x0.clone().requires_grad_(true);
  f(x).sum().backward();
  const at::Tensor analytic = x.grad().reshape({-1});
  const at::Tensor flat = x0.reshape({-1});
  const double h = 1e-6;
  for (int64_t k = 0; k < flat.numel(); ++k) {
    at::Tensor plus = flat.clone(), minus = flat.clone();
    plus[k] += h;
    minus[k] -= h;
    const double numeric = (f(plus.view(x0.sizes())).sum().item<double>() -
                            f(minus.view(x0.sizes())).sum().item<double>()) /
                           (2.0 * h);
    EXPECT_NEAR(analytic[k].item<double>(), numeric, 1e-6 * std::max(1.0, std::abs(numeric)))
        << "element " << k;
  }
}

TEST(Losses, GradientsMatchFiniteDifferences) {
  at::manual_seed(3);
  const at::Tensor rays = pinhole_rays(2, 4, 5, 4.0);
  const at::Tensor distance = plane_distance(rays);
  const at::Tensor gt = distance.unsqueeze(-1) * rays;
  const at::Tensor mask = at::rand({2, 4, 5}, kDouble) > 0.2;
  const at::Tensor log_d = distance.log() + 0.3 * at::randn({2, 4, 5}, kDouble);
  const at::Tensor weight = inverse_distance_weight(gt, mask);
  const at::Tensor scale = at::tensor({0.9, 1.2}, kDouble);

  // L_point at a fixed s* (s* is a constant for the gradient): as a function of log d̂.
  expect_gradient_matches(
      [&](const at::Tensor& ld) {
        return aligned_l1_loss(ld.exp().unsqueeze(-1) * rays, gt, weight, scale);
      },
      log_d);
  // ... and through compute_losses, whose gradient must be the fixed-scale one.
  {
    const at::Tensor ld = log_d.clone().requires_grad_(true);
    LossConfig config;
    config.weights = {1, 0, 0, 0, 0, 0};
    model::OmniPointOutput out = make_output(rays, ld.exp());
    const Losses losses =
        compute_losses(out, make_targets(rays, at::where(mask, distance, at::zeros_like(distance))),
                       config, generator());
    losses.total.backward();
    const at::Tensor fixed = log_d.clone().requires_grad_(true);
    aligned_l1_loss(fixed.exp().unsqueeze(-1) * rays, gt, weight, losses.scale).mean().backward();
    EXPECT_TRUE(at::allclose(ld.grad(), fixed.grad(), 1e-12, 1e-14));
  }
  // L_ray as a function of the raw ray map (normalised inside).
  const at::Tensor raw = rays + 0.2 * at::randn({2, 4, 5, 3}, kDouble);
  expect_gradient_matches(
      [&](const at::Tensor& r) { return ray_loss(r / r.norm(2, {-1}, true), rays, mask); }, raw);
  // L_metric.
  expect_gradient_matches(
      [&](const at::Tensor& s) {
        return metric_scale_loss(s, scale, bools({1, 1}));
      },
      at::tensor({0.3, -0.2}, kDouble));
  // The gauge term.
  expect_gradient_matches([&](const at::Tensor& ld) { return gauge_loss(ld.exp(), mask); }, log_d);
  // L_normal on a perturbed surface (angles between 3° and 90°, away from the clamps).
  const at::Tensor bumpy = gt + 0.15 * at::randn({2, 4, 5, 3}, kDouble);
  expect_gradient_matches([&](const at::Tensor& p) { return normal_loss(p, gt, mask); }, bumpy);
  // L_mask.
  expect_gradient_matches([&](const at::Tensor& logits) { return mask_loss(logits, mask, ~mask); },
                          at::randn({2, 4, 5}, kDouble));
}

TEST(Losses, RejectsBadShapes) {
  const at::Tensor rays = pinhole_rays(1, 4, 4, 4.0);
  model::OmniPointOutput out = make_output(rays, at::ones({1, 4, 4}, kDouble));
  LossTargets targets = make_targets(pinhole_rays(1, 5, 4, 4.0), at::ones({1, 5, 4}, kDouble));
  EXPECT_THROW(compute_losses(out, targets, {}, generator()), std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::train
