// Exact weighted-L1 alignment: closed forms, MoGe's tie rule, and every fast solver against
// an exhaustive reference on random instances (continuous, tied and degenerate).
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "omnipoint/geometry/alignment.h"

using namespace omnipoint::geometry;

namespace {

// Σ w|s x + t − y| in double.
double l1(const at::Tensor& x, const at::Tensor& y, const at::Tensor& w, double s, double t) {
  return (w.to(at::kDouble) * (s * x.to(at::kDouble) + t - y.to(at::kDouble)).abs())
      .sum()
      .item<double>();
}

// Exhaustive minimum of min_a Σ min(trunc, w|a x − y|) over the candidate ratios.
double truncated_reference(const at::Tensor& x, const at::Tensor& y, const at::Tensor& w,
                           double trunc) {
  double best = std::numeric_limits<double>::infinity();
  for (int64_t i = 0; i < x.size(0); ++i) {
    if (x[i].item<double>() == 0) continue;
    const double a = (y[i] / x[i]).item<double>();
    best = std::min(best, (w * (a * x - y).abs()).clamp_max(trunc).sum().item<double>());
  }
  return best;
}

// Random instance: continuous, or drawn from a few integers (many ties and collinear triples).
struct Instance {
  at::Tensor x, y, w;
};
Instance random_instance(int64_t n, bool tied, at::ScalarType dtype) {
  Instance in;
  if (tied) {
    in.x = at::randint(-3, 4, {n}, at::kDouble);
    in.y = at::randint(-3, 4, {n}, at::kDouble);
    in.w = at::randint(0, 3, {n}, at::kDouble);
  } else {
    in.x = at::rand({n}, at::kDouble) * 4 + 0.5;
    in.y = 1.7 * in.x - 0.4 + 0.3 * at::randn({n}, at::kDouble);
    in.y.index_put_({at::rand({n}) < 0.1}, 10.0);  // outliers
    in.w = at::rand({n}, at::kDouble) + 0.1;
  }
  in.x = in.x.to(dtype);
  in.y = in.y.to(dtype);
  in.w = in.w.to(dtype);
  return in;
}

double tolerance(at::ScalarType dtype, double scale) {
  return (dtype == at::kFloat ? 2e-5 : 1e-10) * (1 + scale);
}

}  // namespace

TEST(ScaleFit, WeightedMedianWithMoGeTieRule) {
  const at::Tensor x = at::ones({4}, at::kDouble), y = at::tensor({4.0, 2.0, 3.0, 1.0});
  const ScaleFit fit = fit_scale_l1(x, y, at::ones({4}, at::kDouble));
  EXPECT_EQ(fit.scale.item<double>(), 2.0);  // first whose cumulative weight reaches half
  EXPECT_EQ(fit.index.item<int64_t>(), 1);
  EXPECT_DOUBLE_EQ(fit.loss.item<double>(), 4.0);
}

TEST(ScaleFit, NegativeSourceAndExactScale) {
  const at::Tensor x = at::tensor({-1.0, 2.0, -3.0, 4.0, 0.5}), y = 2.5 * x;
  const ScaleFit fit = fit_scale_l1(x, y, at::rand({5}, at::kDouble) + 0.1);
  EXPECT_DOUBLE_EQ(fit.scale.item<double>(), 2.5);
  EXPECT_NEAR(fit.loss.item<double>(), 0.0, 1e-12);
}

TEST(ScaleFit, BatchedWithMasksIgnoresMaskedGarbage) {
  at::manual_seed(1);
  const at::Tensor x = at::rand({3, 50}, at::kDouble) + 0.5,
                   y = 3 * x + 0.1 * at::randn({3, 50}, at::kDouble);
  const at::Tensor w = at::rand({3, 50}, at::kDouble);
  at::Tensor mask = at::rand({3, 50}) < 0.6;
  mask[2].fill_(false);
  const at::Tensor x_bad = at::where(mask, x, at::full({}, std::nan(""), at::kDouble));
  const ScaleFit fit = fit_scale_l1(x_bad, y, w, mask);
  for (int b = 0; b < 2; ++b) {
    const ScaleFit one = fit_scale_l1(x[b].masked_select(mask[b]), y[b].masked_select(mask[b]),
                                      w[b].masked_select(mask[b]));
    EXPECT_DOUBLE_EQ(fit.scale[b].item<double>(), one.scale.item<double>());
  }
  EXPECT_TRUE(std::isnan(fit.scale[2].item<double>()));  // empty mask
  EXPECT_EQ(fit.index[2].item<int64_t>(), -1);
}

TEST(ScaleFit, TruncatedMatchesExhaustiveSearch) {
  at::manual_seed(2);
  for (int trial = 0; trial < 40; ++trial) {
    const bool tied = trial % 2 == 1;
    const Instance in = random_instance(5 + trial, tied, at::kDouble);
    const double trunc = 0.05 + 0.1 * (trial % 5);
    const ScaleFit fit = fit_scale_l1_truncated(in.x, in.y, in.w, trunc);
    const double reference = truncated_reference(in.x, in.y, in.w, trunc);
    if (std::isinf(reference)) {
      EXPECT_TRUE(std::isnan(fit.scale.item<double>()));
      continue;
    }
    EXPECT_NEAR(fit.loss.item<double>(), reference, 1e-9 * (1 + reference)) << "trial " << trial;
  }
}

TEST(ScaleFit, TruncatedIgnoresOutliersThatMoveTheMedian) {
  // 6 inliers on y = 2x, 5 gross outliers: the plain weighted median is pulled away,
  // the truncated fit is not.
  const at::Tensor x = at::tensor({1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 1.0, 1.0, 1.0, 1.0, 1.0});
  const at::Tensor y = at::tensor({2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 50.0, 50.0, 50.0, 50.0, 50.0});
  const at::Tensor w = at::ones({11}, at::kDouble);
  EXPECT_DOUBLE_EQ(fit_scale_l1_truncated(x, y, w, 1.0).scale.item<double>(), 2.0);
}

// Moved from model/test_conditioning.cpp (model::sparse_depth_alignment_scale was this fit).
TEST(SparseDepthScale, IsTheWeightedMedianOfRatios) {
  // Exact data: a constant ratio 2.5 is recovered whatever the outliers' count below half
  // of the weight.
  at::Tensor predicted = at::rand({2, 6, 7}, at::kDouble) + 0.5;
  at::Tensor sparse = at::zeros_like(predicted);
  for (int i = 0; i < 7; ++i) sparse[0][i % 6][i] = 2.5 * predicted[0][i % 6][i];
  sparse[0][5][0] = 40.0 * predicted[0][5][0];  // one gross outlier
  const at::Tensor scale = fit_scale_to_sparse_depth(predicted.flatten(1), sparse.flatten(1));
  EXPECT_NEAR(scale[0].item<double>(), 2.5, 1e-12);
  EXPECT_EQ(scale[1].item<double>(), 1.0);  // no samples: unchanged

  // Against the definition: the minimiser of Σ |a x − y| / y over a fine search.
  at::Tensor noisy = at::zeros({1, 1, 5}, at::kDouble);
  at::Tensor x = at::tensor({1.0, 2.0, 0.5, 3.0, 1.5}, at::kDouble).view({1, 1, 5});
  noisy[0][0] = at::tensor({1.3, 1.9, 0.9, 4.4, 1.2}, at::kDouble);
  const double a = fit_scale_to_sparse_depth(x.flatten(1), noisy.flatten(1)).item<double>();
  const auto cost = [&](double s) { return ((s * x - noisy).abs() / noisy).sum().item<double>(); };
  for (double s = 0.5; s < 2.0; s += 1e-3) EXPECT_LE(cost(a), cost(s) + 1e-12);
}

TEST(AffineFit, RecoversExactLine) {
  const at::Tensor x = at::tensor({0.5, 1.0, 2.0, 3.5, 7.0}), y = 2 * x + 3;
  const AffineFit fit = fit_affine_l1(x, y, at::ones({5}, at::kDouble));
  EXPECT_NEAR(fit.scale.item<double>(), 2.0, 1e-12);
  EXPECT_NEAR(fit.shift.item<double>(), 3.0, 1e-12);
  EXPECT_NEAR(fit.loss.item<double>(), 0.0, 1e-12);
}

TEST(AffineFit, FastEqualsBruteForceOnRandomInstances) {
  at::manual_seed(3);
  for (const auto dtype : {at::kDouble, at::kFloat}) {
    for (int trial = 0; trial < 60; ++trial) {
      const bool tied = trial % 3 == 2;
      const int64_t n = trial < 6 ? trial + 1 : 8 + 7 * trial;
      const Instance in = random_instance(n, tied, dtype);
      const AffineFit fast = fit_affine_l1(in.x, in.y, in.w);
      const AffineFit brute = fit_affine_l1_brute_force(in.x, in.y, in.w);
      SCOPED_TRACE(testing::Message() << "trial " << trial << " n " << n << " dtype " << dtype);
      if (!(in.w > 0).any().item<bool>()) {
        EXPECT_TRUE(std::isnan(fast.scale.item<double>()));
        continue;
      }
      const double best =
          l1(in.x, in.y, in.w, brute.scale.item<double>(), brute.shift.item<double>());
      const double got = l1(in.x, in.y, in.w, fast.scale.item<double>(), fast.shift.item<double>());
      EXPECT_NEAR(got, best, tolerance(dtype, best));
      EXPECT_NEAR(fast.loss.item<double>(), got, tolerance(dtype, got));
      if (!tied && dtype == at::kDouble && n > 20) {  // unique optimum: the same line
        EXPECT_NEAR(fast.scale.item<double>(), brute.scale.item<double>(), 1e-9);
        EXPECT_NEAR(fast.shift.item<double>(), brute.shift.item<double>(), 1e-9);
      }
    }
  }
}

TEST(AffineFit, DegenerateInputsStayFinite) {
  const at::Tensor w = at::ones({6}, at::kDouble);
  const at::Tensor constant_x = at::full({6}, 2.0, at::kDouble),
                   y = at::tensor({1.0, 5.0, 2.0, 2.0, 9.0, 3.0});
  const AffineFit fit = fit_affine_l1(constant_x, y, w);  // any scale is optimal
  EXPECT_TRUE(std::isfinite(fit.scale.item<double>()));
  EXPECT_NEAR(fit.loss.item<double>(), l1(constant_x, y, w, 0.0, 2.0), 1e-12);  // the median of y
  const AffineFit single =
      fit_affine_l1(at::tensor({1.0}), at::tensor({4.0}), at::ones({1}, at::kDouble));
  EXPECT_NEAR(single.loss.item<double>(), 0.0, 1e-12);
  const AffineFit empty = fit_affine_l1(y, y, w, at::zeros({6}, at::kBool));
  EXPECT_TRUE(std::isnan(empty.scale.item<double>()));
  EXPECT_TRUE(std::isnan(empty.shift.item<double>()));
}

TEST(Alignment, NoSamplesGiveNaN) {
  const at::Tensor none = at::zeros({2, 0}, at::kDouble), none3 = at::zeros({2, 0, 3}, at::kDouble);
  EXPECT_TRUE(at::isnan(fit_scale_l1(none, none, none).scale).all().item<bool>());
  EXPECT_TRUE(at::isnan(fit_scale_l1_truncated(none, none, none, 1.0).scale).all().item<bool>());
  EXPECT_TRUE(at::isnan(fit_affine_l1(none, none, none).scale).all().item<bool>());
  EXPECT_TRUE(at::isnan(fit_affine_l1_brute_force(none, none, none).shift).all().item<bool>());
  EXPECT_TRUE(at::isnan(fit_points_affine_l1(none3, none3, none).shift).all().item<bool>());
  EXPECT_TRUE(
      at::isnan(fit_points_affine_l1_anchored(none3, none3, none).scale).all().item<bool>());
  EXPECT_TRUE(at::isnan(fit_points_shift_l1(none3, none3, none)).all().item<bool>());
  EXPECT_TRUE(at::isnan(fit_points_scale_l1(none3, none3, none).scale).all().item<bool>());
}

TEST(AffineFit, BatchedWithMasksEqualsPerItem) {
  at::manual_seed(4);
  const at::Tensor x = at::rand({4, 200}, at::kFloat) + 0.5,
                   y = 0.7 * x - 2 + 0.05 * at::randn({4, 200});
  const at::Tensor w = at::rand({4, 200}), mask = at::rand({4, 200}) < 0.7;
  const AffineFit fit = fit_affine_l1(x, y, w, mask);
  for (int b = 0; b < 4; ++b) {
    const AffineFit one = fit_affine_l1_brute_force(
        x[b].masked_select(mask[b]), y[b].masked_select(mask[b]), w[b].masked_select(mask[b]));
    EXPECT_NEAR(fit.loss[b].item<double>(), one.loss.item<double>(),
                1e-4 * one.loss.item<double>());
  }
}

TEST(PointsFit, ShiftIsPerAxisWeightedMedian) {
  at::manual_seed(5);
  const at::Tensor p = at::randn({30, 3}, at::kDouble),
                   g = p + at::tensor({0.5, -1.0, 2.0}) + 0.01 * at::randn({30, 3}, at::kDouble);
  const at::Tensor w = at::rand({30}, at::kDouble);
  const at::Tensor shift = fit_points_shift_l1(p, g, w);
  ASSERT_EQ(shift.sizes(), at::IntArrayRef({3}));
  for (int c = 0; c < 3; ++c) {
    const ScaleFit axis =
        fit_scale_l1(at::ones({30}, at::kDouble), g.select(1, c) - p.select(1, c), w);
    EXPECT_DOUBLE_EQ(shift[c].item<double>(), axis.scale.item<double>());
  }
}

TEST(PointsFit, ScalePoolsCoordinates) {
  const at::Tensor p = at::tensor({1.0, 2.0, 3.0, -1.0, 0.5, 2.0}).view({2, 3});
  const ScaleFit fit = fit_points_scale_l1(p, 1.5 * p, at::ones({2}, at::kDouble));
  EXPECT_DOUBLE_EQ(fit.scale.item<double>(), 1.5);
  const ScaleFit truncated = fit_points_scale_l1(p, 1.5 * p, at::ones({2}, at::kDouble), {}, 0.1);
  EXPECT_DOUBLE_EQ(truncated.scale.item<double>(), 1.5);
}

TEST(PointsFit, GlobalAffineEqualsBreakpointSearch) {
  // The global optimum's scale is a pairwise slope within one axis: scan all of them.
  at::manual_seed(6);
  for (int trial = 0; trial < 12; ++trial) {
    const int64_t n = 4 + trial;
    at::Tensor p = at::randn({n, 3}, at::kDouble),
               g = 1.3 * p + at::randn({3}, at::kDouble) + 0.2 * at::randn({n, 3}, at::kDouble);
    if (trial % 3 == 0) p = p.round(), g = g.round();  // ties
    const at::Tensor w = at::rand({n}, at::kDouble) + 0.1;
    auto objective = [&](double s) {
      double total = 0;
      for (int c = 0; c < 3; ++c) {
        const at::Tensor r = g.select(1, c) - s * p.select(1, c);
        total += fit_scale_l1(at::ones({n}, at::kDouble), r, w).loss.item<double>();
      }
      return total;
    };
    double best = objective(0.0);
    for (int c = 0; c < 3; ++c)
      for (int64_t i = 0; i < n; ++i)
        for (int64_t j = i + 1; j < n; ++j) {
          const double dx = (p[j][c] - p[i][c]).item<double>();
          if (dx != 0) best = std::min(best, objective((g[j][c] - g[i][c]).item<double>() / dx));
        }
    const AffineFit fit = fit_points_affine_l1(p, g, w);
    ASSERT_EQ(fit.shift.sizes(), at::IntArrayRef({3}));
    EXPECT_NEAR(fit.loss.item<double>(), best, 1e-9 * (1 + best)) << "trial " << trial;
  }
}

TEST(PointsFit, PrunedAnchoredEqualsBruteForce) {
  at::manual_seed(7);
  for (const auto dtype : {at::kDouble, at::kFloat}) {
    for (int trial = 0; trial < 16; ++trial) {
      const int64_t n = 3 + 37 * trial;
      at::Tensor p = at::rand({n, 3}, at::kDouble) * 4 - 2,
                 g = 0.8 * p + at::randn({3}, at::kDouble);
      g = g + 0.1 * at::randn({n, 3}, at::kDouble) * (at::rand({n, 1}) < 0.1).to(at::kDouble) * 30;
      if (trial % 4 == 3) p = p.round(), g = g.round();
      const at::Tensor w = (at::rand({n}, at::kDouble) + 0.1).to(dtype);
      p = p.to(dtype), g = g.to(dtype);
      const AffineFit fast = fit_points_affine_l1_anchored(p, g, w);
      const AffineFit brute = fit_points_affine_l1_anchored_brute_force(p, g, w);
      SCOPED_TRACE(testing::Message() << "trial " << trial << " dtype " << dtype);
      const double best = brute.loss.item<double>();
      EXPECT_NEAR(fast.loss.item<double>(), best, tolerance(dtype, best));
      if (dtype == at::kDouble && trial % 4 != 3) {
        EXPECT_NEAR(fast.scale.item<double>(), brute.scale.item<double>(), 1e-9);
      }
    }
  }
}

TEST(PointsFit, TruncatedScaleZShiftEqualsVertexSearch) {
  // Independent reference: the minimum lies where two zero-residual lines of the terms
  // cross in the (s, t_z) plane (x/y terms: s = g/p; z terms: s·p_z + t = g_z).
  at::manual_seed(9);
  for (int trial = 0; trial < 10; ++trial) {
    const int64_t n = 4 + trial % 4;
    const at::Tensor p = at::rand({n, 3}, at::kDouble) + 0.2;
    at::Tensor g =
        1.6 * p + at::tensor({0.0, 0.0, 0.7}, at::kDouble) + 0.05 * at::randn({n, 3}, at::kDouble);
    g[0][1] = 9.0;  // an outlier the truncation ignores
    const at::Tensor w = at::rand({n}, at::kDouble) + 0.5;
    const double trunc = 0.3;
    auto objective = [&](double s, double t) {
      const at::Tensor shift = at::tensor({0.0, 0.0, t}, at::kDouble);
      return (w.unsqueeze(-1) * (s * p + shift - g).abs()).clamp_max(trunc).sum().item<double>();
    };
    double best = std::numeric_limits<double>::infinity();
    for (int64_t k = 0; k < n; ++k)
      for (int64_t j = 0; j < n; ++j)
        for (int c = 0; c < 3; ++c) {
          const double pk = p[k][c].item<double>(), gk = g[k][c].item<double>();
          const double pz = p[j][2].item<double>(), gz = g[j][2].item<double>();
          double s;
          if (c < 2) {
            s = gk / pk;
          } else {
            if (pk == pz) continue;
            s = (gk - gz) / (pk - pz);
          }
          best = std::min(best, objective(s, gz - s * pz));
        }
    const AffineFit fit = fit_points_scale_z_shift_l1_truncated(p, g, w, trunc);
    EXPECT_NEAR(fit.loss.item<double>(), best, 1e-9) << "trial " << trial;
    EXPECT_EQ(fit.shift[0].item<double>(), 0.0);
    EXPECT_NEAR(objective(fit.scale.item<double>(), fit.shift[2].item<double>()), best, 1e-9);
  }
}

TEST(Alignment, RejectsMismatchedShapes) {
  const at::Tensor a = at::ones({5}), b = at::ones({4});
  EXPECT_THROW(fit_scale_l1(a, b, a), std::invalid_argument);
  EXPECT_THROW(fit_affine_l1(a, a, b), std::invalid_argument);
  EXPECT_THROW(fit_points_scale_l1(at::ones({5, 2}), at::ones({5, 2}), a), std::invalid_argument);
  EXPECT_THROW(fit_scale_l1_truncated(a, a, a, 0.0), std::invalid_argument);
}

TEST(Alignment, CudaMatchesCpu) {
  if (!at::hasCUDA()) GTEST_SKIP() << "no CUDA device";
  at::manual_seed(8);
  const Instance in = random_instance(500, false, at::kFloat);
  const AffineFit cpu = fit_affine_l1(in.x, in.y, in.w);
  const AffineFit gpu = fit_affine_l1(in.x.cuda(), in.y.cuda(), in.w.cuda());
  EXPECT_NEAR(gpu.loss.cpu().item<double>(), cpu.loss.item<double>(),
              1e-4 * cpu.loss.item<double>());
  const at::Tensor p = at::rand({300, 3}) + 1, g = 2 * p + 0.1 * at::randn({300, 3});
  const at::Tensor w = at::rand({300});
  const AffineFit a = fit_points_affine_l1_anchored(p, g, w);
  const AffineFit b = fit_points_affine_l1_anchored(p.cuda(), g.cuda(), w.cuda());
  EXPECT_NEAR(b.loss.cpu().item<double>(), a.loss.item<double>(), 1e-4 * a.loss.item<double>());
  const ScaleFit t = fit_scale_l1_truncated(in.x, in.y, in.w, 0.2);
  const ScaleFit u = fit_scale_l1_truncated(in.x.cuda(), in.y.cuda(), in.w.cuda(), 0.2);
  EXPECT_NEAR(u.loss.cpu().item<double>(), t.loss.item<double>(), 1e-4 * t.loss.item<double>());
}
