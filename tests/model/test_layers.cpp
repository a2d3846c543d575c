// The network's own layers (model/layers.h) against LibTorch's: the same parameter names and
// shapes, the same initial values drawn in the same order, the same outputs; and left unfilled
// under SkipParameterInit.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>

#include <functional>
#include <map>
#include <string>

#include "omnipoint/model/layers.h"
#include "omnipoint/model/state_dict.h"

namespace omnipoint::model {
namespace {

std::map<std::string, at::Tensor> parameters(const torch::nn::Module& module) {
  std::map<std::string, at::Tensor> out;
  for (const auto& item : module.named_parameters()) out[item.key()] = item.value();
  return out;
}

// Built after the same seed, `ours` holds LibTorch's initial values under LibTorch's names, and
// the next draw after both is the same; on the same input both give the same output.
template <typename Ours, typename Theirs>
void expect_like_libtorch(const std::function<Ours()>& make_ours,
                          const std::function<Theirs()>& make_theirs, const at::Tensor& input) {
  at::manual_seed(11);
  Ours ours = make_ours();
  const double after_ours = at::rand({1}).item<double>();
  at::manual_seed(11);
  Theirs theirs = make_theirs();
  const double after_theirs = at::rand({1}).item<double>();
  EXPECT_EQ(after_ours, after_theirs);
  const auto mine = parameters(*ours);
  const auto reference = parameters(*theirs);
  ASSERT_EQ(mine.size(), reference.size());
  for (const auto& [name, tensor] : reference) {
    ASSERT_EQ(mine.count(name), 1u) << name;
    EXPECT_TRUE(at::equal(mine.at(name), tensor)) << name;
  }
  EXPECT_TRUE(at::equal(ours->forward(input), theirs->forward(input)));
}

TEST(Layers, LinearIsLibTorchs) {
  // Batched and large enough that a different summation order would show in the last bits.
  const at::Tensor batched = at::randn({3, 197, 384});
  for (const bool bias : {true, false}) {
    for (const at::Tensor& input : {batched, batched[0]}) {
      expect_like_libtorch<Linear, torch::nn::Linear>(
          [&] { return Linear(torch::nn::LinearOptions(384, 1152).bias(bias)); },
          [&] { return torch::nn::Linear(torch::nn::LinearOptions(384, 1152).bias(bias)); }, input);
    }
  }
}

TEST(Layers, Conv2dIsLibTorchs) {
  const at::Tensor input = at::randn({2, 4, 9, 7});
  const torch::nn::Conv2dOptions plain = torch::nn::Conv2dOptions(4, 6, 3).stride(2).padding(1);
  const torch::nn::Conv2dOptions replicate =
      torch::nn::Conv2dOptions(4, 6, {3, 5}).padding({1, 2}).padding_mode(torch::kReplicate);
  const torch::nn::Conv2dOptions grouped = torch::nn::Conv2dOptions(4, 6, 1).groups(2).bias(false);
  for (const auto& options : {plain, replicate, grouped}) {
    expect_like_libtorch<Conv2d, torch::nn::Conv2d>(
        [&] { return Conv2d(options); }, [&] { return torch::nn::Conv2d(options); }, input);
  }
}

TEST(Layers, ConvTranspose2dIsLibTorchs) {
  const at::Tensor input = at::randn({2, 4, 5, 6});
  const auto options = torch::nn::ConvTranspose2dOptions(4, 3, 2).stride(2);
  expect_like_libtorch<ConvTranspose2d, torch::nn::ConvTranspose2d>(
      [&] { return ConvTranspose2d(options); }, [&] { return torch::nn::ConvTranspose2d(options); },
      input);
}

TEST(Layers, SkippedInitialisationDrawsNothingAndLoadsStrictly) {
  at::manual_seed(5);
  const double untouched = at::rand({1}).item<double>();
  at::manual_seed(5);
  Linear linear{nullptr};
  Conv2d conv{nullptr};
  {
    const SkipParameterInit skip;
    linear = Linear(6, 4);
    conv = Conv2d(torch::nn::Conv2dOptions(4, 6, 3).padding(1).padding_mode(torch::kReplicate));
  }
  EXPECT_EQ(at::rand({1}).item<double>(), untouched);  // no random number was drawn
  EXPECT_EQ(linear->weight.sizes(), (std::vector<int64_t>{4, 6}));
  EXPECT_EQ(conv->weight.sizes(), (std::vector<int64_t>{6, 4, 3, 3}));
  EXPECT_TRUE(linear->weight.requires_grad());
  // Outside the scope, layers initialise again.
  at::manual_seed(5);
  Linear initialised(6, 4);
  EXPECT_NE(at::rand({1}).item<double>(), untouched);
  const std::map<std::string, at::Tensor> weights = {{"weight", at::ones({4, 6})},
                                                     {"bias", at::zeros({4})}};
  load_state_dict(*linear, weights, LoadMode::kStrict);
  EXPECT_TRUE(at::equal(linear->forward(at::ones({1, 6})), at::full({1, 4}, 6.0)));
}

TEST(Layers, PaddingByNameIsRefused) {
  EXPECT_THROW(Conv2d(torch::nn::Conv2dOptions(4, 6, 3).padding(torch::kSame)),
               std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::model
