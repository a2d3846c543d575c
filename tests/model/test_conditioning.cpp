// The conditioning pieces on their own: presence rules, state embeddings, the zero-initialised
// encoders, the sparse-depth input of the ViT grid and the metric post-alignment.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <torch/nn/init.h>

#include <cmath>
#include <initializer_list>
#include <stdexcept>
#include <vector>

#include "omnipoint/model/conditioning.h"

namespace omnipoint::model {
namespace {

at::Tensor flags(std::initializer_list<int> values) {
  return at::tensor(std::vector<int>(values), at::kInt).to(at::kBool);
}

TEST(Conditioning, PresenceFollowsTheValidValuesOfEachItem) {
  at::Tensor rays = at::zeros({3, 3, 4, 5});
  rays[1][2][3][4] = 1.0;
  rays[2].select(0, 2).fill_(1.0);
  EXPECT_TRUE(at::equal(rays_present(rays), flags({0, 1, 1})));
  rays[0][1][2][2] = NAN;  // a non-finite ray carries nothing
  EXPECT_TRUE(at::equal(rays_present(rays), flags({0, 1, 1})));
  EXPECT_EQ(valid_rays(rays)[0].abs().sum().item<float>(), 0.0f);

  at::Tensor depth = at::zeros({4, 4, 5});
  depth[1][0][0] = 2.5;
  depth[2][1][1] = -1.0;  // negative: not a distance
  depth[3][2][2] = INFINITY;
  EXPECT_TRUE(at::equal(sparse_depth_present(depth), flags({0, 1, 0, 0})));

  EXPECT_THROW(rays_present(at::zeros({2, 4, 5})), std::invalid_argument);
  EXPECT_THROW(sparse_depth_present(at::zeros({2, 1, 4, 5})), std::invalid_argument);
}

TEST(Conditioning, StateEmbeddingPicksThePresentOrAbsentRow) {
  torch::nn::Embedding embedding = make_state_embedding(4);
  EXPECT_EQ(embedding->weight.abs().sum().item<double>(), 0.0);  // starts neutral
  {
    at::NoGradGuard no_grad;
    embedding->weight.copy_(at::arange(8, at::kFloat).view({2, 4}));
  }
  const at::Tensor e = state_embedding(embedding, flags({1, 0, 1}));
  ASSERT_EQ(e.sizes(), (at::IntArrayRef{3, 1, 4}));
  EXPECT_TRUE(at::equal(e[0][0], embedding->weight[1]));
  EXPECT_TRUE(at::equal(e[1][0], embedding->weight[0]));
  EXPECT_TRUE(at::equal(e[2][0], embedding->weight[1]));
}

TEST(Conditioning, EncoderIsZeroUntilTrainedAndPatchAligned) {
  ConditionEncoder encoder(2, 8, 6, 14);
  const at::Tensor x = at::rand({2, 2, 28, 42});
  const at::Tensor tokens = encoder->forward(x);
  ASSERT_EQ(tokens.sizes(), (at::IntArrayRef{2, 6, 6}));
  EXPECT_EQ(tokens.abs().max().item<double>(), 0.0);

  torch::nn::init::normal_(encoder->fuse->weight);
  // Changing one pixel of patch (row 1, col 2) changes exactly token 1·3 + 2.
  at::Tensor y = x.clone();
  y[0][0][20][30] += 1.0;
  const at::Tensor change = (encoder->forward(y) - encoder->forward(x)).abs().sum(2);
  EXPECT_GT(change[0][5].item<double>(), 0.0);
  EXPECT_EQ(change.sum().item<double>(), change[0][5].item<double>());
}

TEST(Conditioning, SparseDepthFeaturesAreNormalisedSamplesOnTheGrid) {
  // 2 items at 8×12 -> grid 4×6: item 0 has two samples, item 1 none.
  at::Tensor depth = at::zeros({2, 8, 12}, at::kDouble);
  depth[0][1][3] = 2.0;   // centre (3.5, 1.5) -> grid (col 1, row 0)
  depth[0][6][10] = 6.0;  // centre (10.5, 6.5) -> grid (col 5, row 3)
  ConditioningConfig config;
  config.gaussian_smoothing = false;
  const at::Tensor features = sparse_depth_features(depth, 4, 6, config);
  ASSERT_EQ(features.sizes(), (at::IntArrayRef{2, 2, 4, 6}));
  EXPECT_EQ(features.scalar_type(), at::kDouble);
  at::Tensor expected = at::zeros({2, 2, 4, 6}, at::kDouble);
  expected[0][0][0][1] = 0.5;  // divided by the mean 4
  expected[0][0][3][5] = 1.5;
  expected[0][1][0][1] = 1.0;
  expected[0][1][3][5] = 1.0;
  EXPECT_TRUE(at::allclose(features, expected, 0.0, 1e-12));

  config.gaussian_smoothing = true;
  const at::Tensor smooth = sparse_depth_features(depth, 4, 6, config);
  EXPECT_TRUE(at::equal(smooth.select(1, 1), expected.select(1, 1)));  // the mask
  EXPECT_GT((smooth[0][0] > 0).sum().item<int64_t>(), 2);              // spread out
  EXPECT_EQ(smooth[1].abs().max().item<double>(), 0.0);
}

TEST(Conditioning, SamplesSharingAGridPixelAreAveraged) {
  at::Tensor depth = at::zeros({1, 4, 4});
  depth[0][0][0] = 1.0;
  depth[0][1][1] = 3.0;  // both in grid pixel (0,0) of 2×2
  depth[0][3][3] = 2.0;
  ConditioningConfig config;
  config.gaussian_smoothing = false;
  const at::Tensor features = sparse_depth_features(depth, 2, 2, config);
  // grid values 2 and 2 -> mean 2 -> normalised 1.
  EXPECT_FLOAT_EQ(features[0][0][0][0].item<float>(), 1.0f);
  EXPECT_FLOAT_EQ(features[0][0][1][1].item<float>(), 1.0f);
  EXPECT_EQ(features[0][1].sum().item<float>(), 2.0f);
}

}  // namespace
}  // namespace omnipoint::model
