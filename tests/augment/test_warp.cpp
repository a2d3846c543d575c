// The sampling rule shared by P2A and A2P (warp.h) on closed-form maps: bilinear on a plane,
// nothing across a depth step, the border clamp, and what lies outside or is not a number.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>

#include "omnipoint/augment/warp.h"

namespace omnipoint::augment {
namespace {

// d(x, y) = 2 + 0.02 x + 0.01 y at the pixel centres (x, y) = (i + 0.5, j + 0.5):
// neighbours agree within 1.5 %.
at::Tensor plane(int64_t height, int64_t width, at::ScalarType dtype) {
  const at::Tensor xs = at::arange(width, at::kDouble) + 0.5;
  const at::Tensor ys = at::arange(height, at::kDouble) + 0.5;
  return (2.0 + 0.02 * xs.unsqueeze(0) + 0.01 * ys.unsqueeze(1)).to(dtype);
}

TEST(SampleDistance, BilinearIsExactOnAPlaneInBothPrecisions) {
  for (const auto dtype : {at::kFloat, at::kDouble}) {
    const at::Tensor d = plane(6, 8, dtype);
    const at::Tensor valid = at::ones({6, 8}, at::kBool);
    const at::Tensor pixels =
        at::tensor({0.5, 0.5, 3.25, 2.75, 7.5, 5.5, 4.0, 3.0, 1.9, 4.1}, at::kDouble).view({5, 2});
    const SampledDistance s = sample_distance(d, valid, pixels, 0.05);
    ASSERT_EQ(s.value.scalar_type(), dtype);
    ASSERT_EQ(s.value.sizes(), at::IntArrayRef({5}));
    for (int64_t i = 0; i < 5; ++i) {
      const double x = pixels[i][0].item<double>(), y = pixels[i][1].item<double>();
      EXPECT_TRUE(s.ok[i].item<bool>()) << i;
      EXPECT_NEAR(s.value[i].item<double>(), 2.0 + 0.02 * x + 0.01 * y, 1e-5) << i;
    }
  }
}

TEST(SampleDistance, BorderClampsAndOutsideIsNotOk) {
  const at::Tensor d = plane(4, 5, at::kDouble);
  const at::Tensor valid = at::ones({4, 5}, at::kBool);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Within half a pixel of the border: the border pixel's value. Beyond [0, W] x [0, H] or NaN:
  // not ok and 0.
  const at::Tensor pixels =
      at::tensor({0.1, 0.2, 5.0, 4.0, -0.01, 1.0, 5.01, 1.0, 1.0, 4.2, nan, 1.0}, at::kDouble)
          .view({2, 3, 2});
  const SampledDistance s = sample_distance(d, valid, pixels, 0.05);
  ASSERT_EQ(s.value.sizes(), at::IntArrayRef({2, 3}));
  EXPECT_TRUE(s.ok[0][0].item<bool>());
  EXPECT_NEAR(s.value[0][0].item<double>(), d[0][0].item<double>(), 1e-12);
  EXPECT_TRUE(s.ok[0][1].item<bool>());
  EXPECT_NEAR(s.value[0][1].item<double>(), d[3][4].item<double>(), 1e-12);
  const std::pair<int, int> outside[] = {{0, 2}, {1, 0}, {1, 1}, {1, 2}};
  for (const auto& [row, col] : outside) {
    EXPECT_FALSE(s.ok[row][col].item<bool>()) << row << " " << col;
    EXPECT_EQ(s.value[row][col].item<double>(), 0.0) << row << " " << col;
  }
}

TEST(SampleDistance, NoBlendAcrossADepthStepOrAnUnlabelledCorner) {
  // Columns 0-2 at 1 m, columns 3-5 at 3 m; pixel (1, 4) is unlabelled.
  at::Tensor d = at::ones({4, 6}, at::kDouble);
  d.narrow(1, 3, 3).fill_(3.0);
  at::Tensor valid = at::ones({4, 6}, at::kBool);
  valid[1][4] = false;
  const at::Tensor pixels =
      at::tensor({1.5, 2.0, 3.0, 2.0, 5.0, 1.0, 5.0, 3.5}, at::kDouble).view({4, 2});
  const SampledDistance s = sample_distance(d, valid, pixels, 0.05);
  EXPECT_TRUE(s.ok[0].item<bool>());  // inside the near half
  EXPECT_NEAR(s.value[0].item<double>(), 1.0, 1e-12);
  EXPECT_FALSE(s.ok[1].item<bool>());  // the quad straddles the step
  EXPECT_FALSE(s.ok[2].item<bool>());  // a corner is unlabelled
  EXPECT_TRUE(s.ok[3].item<bool>());   // far half, labelled quad
  EXPECT_NEAR(s.value[3].item<double>(), 3.0, 1e-12);
  // Non-finite and non-positive distances count as unlabelled.
  d[2][1] = std::numeric_limits<double>::infinity();
  d[0][1] = 0.0;
  const SampledDistance bad =
      sample_distance(d, at::ones({4, 6}, at::kBool),
                      at::tensor({1.5, 2.5, 1.5, 0.6}, at::kDouble).view({2, 2}), 0.05);
  EXPECT_FALSE(bad.ok.any().item<bool>());
}

// sample_image is grid_sample (bilinear, border padding, align_corners = false) in pixel
// coordinates: the same colours at positions inside, on the border and far outside, in both
// precisions, for 1 and 4 channels.
TEST(SampleImage, MatchesGridSampleWithBorderPadding) {
  at::manual_seed(3);
  for (const auto dtype : {at::kFloat, at::kDouble}) {
    for (const int64_t channels : {1, 4}) {
      const at::Tensor image = at::rand({7, 9, channels}, dtype);
      at::Tensor pixels = at::rand({500, 2}, at::kDouble) * at::tensor({13.0, 11.0}) - 2;
      pixels = at::cat(
          {pixels, at::tensor({0.0, 0.0, 9.0, 7.0, 0.5, 0.5, 8.5, 6.5, 1e6, -1e6}, at::kDouble)
                       .view({5, 2})});
      const at::Tensor sampled = sample_image(image, pixels.view({5, 101, 2}));
      ASSERT_EQ(sampled.sizes(), at::IntArrayRef({5, 101, channels}));
      ASSERT_EQ(sampled.scalar_type(), dtype);
      const at::Tensor p = pixels.to(dtype);
      const at::Tensor grid =
          at::stack({p.select(-1, 0) * (2.0 / 9) - 1, p.select(-1, 1) * (2.0 / 7) - 1}, -1)
              .view({1, 1, -1, 2});
      const at::Tensor reference =
          at::grid_sampler_2d(image.permute({2, 0, 1}).unsqueeze(0), grid, /*bilinear*/ 0,
                              /*border*/ 1, /*align_corners*/ false)
              .view({channels, -1})
              .t();
      EXPECT_TRUE(at::allclose(sampled.view({-1, channels}), reference, 1e-5, 1e-6))
          << (sampled.view({-1, channels}) - reference).abs().max().item<double>();
    }
  }
}

// A NaN or infinite position gives a colour of the image (P2A and A2P mark such samples
// invalid through the projection), never a read outside it.
TEST(SampleImage, NonFinitePositionsStayInsideTheImage) {
  const at::Tensor image = at::rand({4, 5, 3});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const at::Tensor pixels = at::tensor({nan, 1.0, 1.0, nan, inf, -inf, nan, nan}).view({4, 2});
  const at::Tensor sampled = sample_image(image, pixels);
  EXPECT_TRUE(at::isfinite(sampled).all().item<bool>());
  EXPECT_LE(sampled.max().item<double>(), image.max().item<double>());
}

}  // namespace
}  // namespace omnipoint::augment
