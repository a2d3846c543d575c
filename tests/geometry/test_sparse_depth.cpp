#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>

#include "omnipoint/geometry/sparse_depth.h"

using omnipoint::geometry::splat_sparse_depth;
using omnipoint::geometry::SplatOptions;

namespace {

// The definition written out pixel by pixel, for comparison with the vectorised version.
at::Tensor loop_reference(const at::Tensor& sparse, const SplatOptions& o) {
  const auto s = sparse.to(at::kDouble).contiguous();
  const int64_t h = s.size(0), w = s.size(1);
  auto a = s.accessor<double, 2>();
  double sum = 0;
  int64_t n = 0;
  for (int64_t v = 0; v < h; ++v)
    for (int64_t u = 0; u < w; ++u)
      if (a[v][u] != 0) sum += std::abs(a[v][u]), ++n;
  const double scale = n > 0 ? sum / n : 1.0;
  auto num = at::zeros({h, w}, at::kDouble), den = at::zeros({h, w}, at::kDouble);
  auto an = num.accessor<double, 2>(), ad = den.accessor<double, 2>();
  const double r = static_cast<double>(o.radius);
  for (int64_t v = 0; v < h; ++v)
    for (int64_t u = 0; u < w; ++u) {
      if (a[v][u] == 0) continue;
      const double value = a[v][u] / scale;
      const double sigma = std::min(std::max(o.sigma_per_depth * std::abs(value), o.min_sigma),
                                    std::max(r, o.min_sigma));
      for (int64_t y = 0; y < h; ++y)
        for (int64_t x = 0; x < w; ++x) {
          const double d2 = double((x - u) * (x - u) + (y - v) * (y - v));
          if (d2 > r * r) continue;
          const double wt = std::exp(-d2 / (2 * sigma * sigma));
          an[y][x] += wt * value;
          ad[y][x] += wt;
        }
    }
  return at::where(den > 0, num / den.clamp_min(1e-300), at::zeros_like(num));
}

}  // namespace

TEST(SparseDepth, SinglePointReproducesKernel) {
  SplatOptions o;
  o.radius = 4;
  o.sigma_per_depth = 2.0;
  auto s = at::zeros({1, 15, 17}, at::kDouble);
  s[0][7][8] = 5.0;
  // Alone, the sample fills exactly its disc with its normalised value (1).
  auto out = splat_sparse_depth(s, {}, o);
  EXPECT_DOUBLE_EQ(out.scale.item<double>(), 5.0);
  EXPECT_EQ(out.mask.sum().item<double>(), 1.0);
  EXPECT_EQ(out.mask[0][7][8].item<double>(), 1.0);
  for (int64_t y = 0; y < 15; ++y)
    for (int64_t x = 0; x < 17; ++x) {
      const int64_t d2 = (x - 8) * (x - 8) + (y - 7) * (y - 7);
      EXPECT_EQ(out.covered[0][y][x].item<bool>(), d2 <= 16) << y << "," << x;
      EXPECT_NEAR(out.smooth[0][y][x].item<double>(), d2 <= 16 ? 1.0 : 0.0, 1e-12);
    }
  // Two samples whose discs overlap: the blend equals the closed-form kernel ratio.
  auto pair = at::zeros({1, 15, 17}, at::kDouble);
  pair[0][7][6] = 1.0;  // normalised 2/3, σ = max(4/3, 1) = 4/3
  pair[0][7][9] = 2.0;  // normalised 4/3, σ = 8/3
  auto blended = splat_sparse_depth(pair, {}, o);
  const double s1 = 4.0 / 3, s2 = 8.0 / 3;
  for (int64_t x = 5; x <= 10; ++x) {
    const double d1 = double((x - 6) * (x - 6)), d2 = double((x - 9) * (x - 9));
    const double w1 = d1 <= 16 ? std::exp(-d1 / (2 * s1 * s1)) : 0;
    const double w2 = d2 <= 16 ? std::exp(-d2 / (2 * s2 * s2)) : 0;
    const double expected = (w1 * 2.0 / 3 + w2 * 4.0 / 3) / (w1 + w2);
    EXPECT_NEAR(blended.smooth[0][7][x].item<double>(), expected, 1e-12) << x;
  }
}

TEST(SparseDepth, ConstantDepthStaysConstantWhereCovered) {
  auto g = at::make_generator<at::CPUGeneratorImpl>(3);
  auto pick = at::rand({2, 40, 50}, g, at::kFloat) < 0.02;
  auto s = at::where(pick, at::full({2, 40, 50}, 3.5f), at::zeros({2, 40, 50}));
  auto out = splat_sparse_depth(s);
  ASSERT_TRUE(out.covered.any().item<bool>());
  auto inside = out.smooth.masked_select(out.covered);
  EXPECT_LT((inside - 1.0f).abs().max().item<float>(), 1e-6f);
  EXPECT_TRUE(out.smooth.masked_select(out.covered.logical_not()).eq(0).all().item<bool>());
  EXPECT_TRUE(at::allclose(out.scale, at::full({2}, 3.5f)));
  EXPECT_TRUE(out.mask.eq(pick.to(at::kFloat)).all().item<bool>());
}

TEST(SparseDepth, EmptyInputGivesZerosAndUnitScale) {
  auto out = splat_sparse_depth(at::zeros({2, 8, 9}));
  EXPECT_TRUE(out.smooth.eq(0).all().item<bool>());
  EXPECT_TRUE(out.mask.eq(0).all().item<bool>());
  EXPECT_FALSE(out.covered.any().item<bool>());
  EXPECT_TRUE(out.scale.eq(1).all().item<bool>());
  // Non-finite values and masked-out values are not samples either.
  auto s = at::full({1, 4, 4}, std::nanf(""));
  s[0][0][0] = INFINITY;
  auto masked = splat_sparse_depth(s, at::zeros({1, 4, 4}, at::kBool).logical_not());
  EXPECT_TRUE(masked.smooth.eq(0).all().item<bool>());
  EXPECT_TRUE(masked.scale.eq(1).all().item<bool>());
}

TEST(SparseDepth, BatchItemsAreIndependentAndLeadingDimsKept) {
  auto g = at::make_generator<at::CPUGeneratorImpl>(7);
  auto s = at::rand({2, 3, 20, 24}, g, at::kFloat) * 10;
  s = s * (at::rand({2, 3, 20, 24}, g, at::kFloat) < 0.05);
  s[1][2].zero_();
  auto all = splat_sparse_depth(s);
  ASSERT_EQ(all.smooth.sizes(), s.sizes());
  ASSERT_EQ(all.scale.sizes(), (at::IntArrayRef{2, 3}));
  for (int64_t i = 0; i < 2; ++i)
    for (int64_t j = 0; j < 3; ++j) {
      auto one = splat_sparse_depth(s[i][j]);
      EXPECT_TRUE(at::allclose(one.smooth, all.smooth[i][j], 1e-6, 1e-6));
      EXPECT_TRUE(at::equal(one.mask, all.mask[i][j]));
      EXPECT_NEAR(one.scale.item<float>(), all.scale[i][j].item<float>(), 1e-6);
    }
}

TEST(SparseDepth, MatchesLoopReferenceAndFloat64MatchesFloat32) {
  auto g = at::make_generator<at::CPUGeneratorImpl>(11);
  auto s =
      (at::rand({13, 16}, g, at::kDouble) * 4 + 0.2) * (at::rand({13, 16}, g, at::kDouble) < 0.08);
  for (const auto& o : {SplatOptions{}, SplatOptions{2, 1.0, 0.5}, SplatOptions{0, 3.0, 1.0}}) {
    auto reference = loop_reference(s, o);
    auto d = splat_sparse_depth(s, {}, o);
    EXPECT_LT((d.smooth - reference).abs().max().item<double>(), 1e-12);
    auto f = splat_sparse_depth(s.to(at::kFloat), {}, o);
    EXPECT_EQ(f.smooth.scalar_type(), at::kFloat);
    EXPECT_LT((f.smooth.to(at::kDouble) - reference).abs().max().item<double>(), 1e-5);
  }
}

TEST(SparseDepth, RejectsBadInputs) {
  EXPECT_THROW(splat_sparse_depth(at::zeros({5})), std::invalid_argument);
  EXPECT_THROW(splat_sparse_depth(at::zeros({5, 5}, at::kLong)), std::invalid_argument);
  EXPECT_THROW(splat_sparse_depth(at::zeros({5, 5}), at::zeros({5, 4}, at::kBool)),
               std::invalid_argument);
  EXPECT_THROW(splat_sparse_depth(at::zeros({5, 5}), {}, SplatOptions{-1, 1.0, 1.0}),
               std::invalid_argument);
  EXPECT_THROW(splat_sparse_depth(at::zeros({5, 5}), {}, SplatOptions{3, 0.0, 1.0}),
               std::invalid_argument);
}
