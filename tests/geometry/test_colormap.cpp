#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include "omnipoint/geometry/colormap.h"

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#endif

using namespace omnipoint::geometry;

#ifdef OMNIPOINT_WITH_OPENCV
TEST(Colormap, MatchesOpenCV) {
  cv::Mat grey(1, 256, CV_8U);
  for (int i = 0; i < 256; ++i) grey.at<uchar>(0, i) = static_cast<uchar>(i);
  const auto levels = at::arange(256, at::kDouble);
  for (auto [ours, theirs] : {std::pair{Colormap::Turbo, cv::COLORMAP_TURBO},
                              std::pair{Colormap::Viridis, cv::COLORMAP_VIRIDIS}}) {
    cv::Mat bgr;
    cv::applyColorMap(grey, bgr, theirs);
    const auto rgb = apply_colormap(levels, 0, 255, ours) * 255;
    double worst = 0;
    for (int i = 0; i < 256; ++i)
      for (int c = 0; c < 3; ++c)
        worst =
            std::max(worst, std::abs(rgb[i][c].item<double>() - bgr.at<cv::Vec3b>(0, i)[2 - c]));
    EXPECT_LE(worst, 3.0) << static_cast<int>(ours);
  }
}
#endif

TEST(Colormap, EndpointsClampingAndInvalid) {
  const auto v = at::tensor({-5.0f, 0.0f, 10.0f, 20.0f, NAN, 3.0f});
  auto valid = at::ones({6}, at::kBool);
  valid[5] = false;
  const auto rgb = apply_colormap(v, 0, 10, Colormap::Viridis, valid);
  ASSERT_EQ(rgb.sizes(), (at::IntArrayRef{6, 3}));
  EXPECT_EQ(rgb.scalar_type(), at::kFloat);
  EXPECT_TRUE(at::allclose(rgb[0], at::tensor({68.0f, 1.0f, 84.0f}) / 255));
  EXPECT_TRUE(at::equal(rgb[0], rgb[1]));
  EXPECT_TRUE(at::allclose(rgb[2], at::tensor({253.0f, 231.0f, 37.0f}) / 255));
  EXPECT_TRUE(at::equal(rgb[2], rgb[3]));
  EXPECT_TRUE(rgb[4].eq(0).all().item<bool>());
  EXPECT_TRUE(rgb[5].eq(0).all().item<bool>());
  EXPECT_THROW(apply_colormap(v, 0, NAN), std::invalid_argument);
}

TEST(Colormap, DepthNearIsWarmAndInvalidIsBlack) {
  auto depth = at::tensor({1.0, 2.0, 4.0, 0.0, -1.0, INFINITY}, at::kDouble).view({1, 2, 3});
  const auto rgb = colorize_depth(depth);
  ASSERT_EQ(rgb.sizes(), (at::IntArrayRef{1, 2, 3, 3}));
  // Nearest = top of Turbo (dark red), farthest = bottom (dark blue).
  EXPECT_TRUE(at::allclose(rgb[0][0][0], at::tensor({122.0, 4.0, 3.0}, at::kDouble) / 255));
  EXPECT_TRUE(at::allclose(rgb[0][0][2], at::tensor({48.0, 18.0, 59.0}, at::kDouble) / 255));
  EXPECT_TRUE(rgb[0][1].eq(0).all().item<bool>());
  // A map without valid pixels is black, without NaN.
  const auto empty = colorize_depth(at::zeros({4, 4}));
  EXPECT_TRUE(empty.eq(0).all().item<bool>());
}

TEST(Colormap, InterpolatesLinearlyBetweenAnchors) {
  // Turbo's first anchors (48, 18, 59) at 0 and (57, 42, 115) at 8/255: their midpoint at 4/255,
  // in float and double alike; a batch maps element by element.
  for (const auto dtype : {at::kFloat, at::kDouble}) {
    const auto rgb = apply_colormap(at::full({2, 1}, 4.0, dtype), 0, 255) * 255;
    ASSERT_EQ(rgb.sizes(), (at::IntArrayRef{2, 1, 3}));
    EXPECT_TRUE(at::allclose(rgb[1][0], at::tensor({52.5, 30.0, 87.0}, dtype), 1e-5, 1e-4)) << rgb;
  }
}
