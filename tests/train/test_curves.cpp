// The training-curve picture: one panel per series, drawn where the values are.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "omnipoint/train/curves.h"

namespace omnipoint::train {
namespace {

using nlohmann::json;

std::vector<json> decaying_run(int steps) {
  std::vector<json> records;
  for (int s = 1; s <= steps; ++s)
    records.push_back({{"step", s},
                       {"loss", std::exp(-0.05 * s)},
                       {"terms", {{"point", 0.5 / s}, {"ray", 0.1}}},
                       {"skipped", false}});
  records.push_back(
      {{"step", steps}, {"eval", {{"loss", 0.2}, {"points_delta1", 0.7}, {"point", 0.1}}}});
  return records;
}

// Pixels that are neither white (background) nor grey (frames, text), i.e. curve ink.
int64_t coloured_pixels(const at::Tensor& image) {
  const at::Tensor c = image.to(at::kInt);
  const at::Tensor spread = c.amax(-1) - c.amin(-1);
  return (spread > 30).sum().item<int64_t>();
}

TEST(TrainingCurves, OnePanelPerSeriesThreeToARow) {
  const at::Tensor image = render_training_curves(decaying_run(100));
  ASSERT_EQ(image.dim(), 3);
  EXPECT_EQ(image.scalar_type(), at::kByte);
  // loss, point, ray, eval loss, eval points_delta1 (not the eval's loss term "point"): five
  // panels -> two rows of three.
  EXPECT_EQ(image.size(1), 3 * 400);
  EXPECT_EQ(image.size(0), 2 * 230);
  EXPECT_EQ(image.size(2), 3);
  // Every filled panel has curve ink; the sixth (empty) panel has none.
  for (int64_t i = 0; i < 6; ++i) {
    const at::Tensor panel =
        image.slice(0, i / 3 * 230, i / 3 * 230 + 230).slice(1, i % 3 * 400, i % 3 * 400 + 400);
    if (i < 5)
      EXPECT_GT(coloured_pixels(panel), 20) << "panel " << i;
    else
      EXPECT_EQ(coloured_pixels(panel), 0);
  }
}

TEST(TrainingCurves, ADecreasingLossFallsFromTopLeftToBottomRight) {
  const at::Tensor panel =
      render_training_curves(decaying_run(200)).slice(0, 0, 230).slice(1, 0, 400);
  // Dark blue running-mean ink: where it is in the first and the last tenth of the plot width.
  const at::Tensor c = panel.to(at::kInt);
  const at::Tensor mean_ink = (c.select(-1, 2) > 140) & (c.select(-1, 0) < 60);
  const at::Tensor rows = at::arange(230).view({230, 1}).expand({230, 400});
  const auto mean_row = [&](int64_t x0, int64_t x1) {
    const at::Tensor ink = mean_ink.slice(1, x0, x1);
    return rows.slice(1, x0, x1).masked_select(ink).to(at::kDouble).mean().item<double>();
  };
  EXPECT_LT(mean_row(12, 50), mean_row(340, 388));  // smaller row = higher up
}

TEST(TrainingCurves, SkipsNonFiniteAndRejectsEmptyLogs) {
  std::vector<json> records = decaying_run(20);
  records.push_back({{"step", 21}, {"loss", nullptr}, {"skipped", true}});
  EXPECT_NO_THROW(render_training_curves(records));
  EXPECT_THROW(render_training_curves({}), std::invalid_argument);
  EXPECT_THROW(render_training_curves({json{{"note", "no steps"}}}), std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::train
