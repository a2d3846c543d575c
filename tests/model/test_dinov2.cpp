// The DINOv2 ViT beyond the fixture's configuration: hub names and checkpoint key names,
// registers, no LayerScale, SwiGLU, attention head grouping at high token counts.
#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <set>
#include <string>

#include "omnipoint/model/dinov2.h"
#include "omnipoint/model/state_dict.h"

namespace {

using namespace omnipoint::model;

std::set<std::string> names(torch::nn::Module& module) {
  std::set<std::string> result;
  for (const auto& [name, tensor] : state_dict(module)) result.insert(name);
  return result;
}

TEST(DinoV2, HubViTSmallHasTheCheckpointNamesAndShapes) {
  DinoV2 vit(DinoV2Config::hub("dinov2_vits14"));
  const auto keys = names(*vit);
  for (const char* key :
       {"patch_embed.proj.weight", "cls_token", "pos_embed", "mask_token", "blocks.0.norm1.weight",
        "blocks.0.attn.qkv.weight", "blocks.0.attn.proj.bias", "blocks.0.ls1.gamma",
        "blocks.11.mlp.fc1.weight", "blocks.11.mlp.fc2.bias", "blocks.11.ls2.gamma", "norm.bias"}) {
    EXPECT_TRUE(keys.count(key)) << key;
  }
  // patch_embed (2), cls, pos, mask, 12 blocks × 14 tensors, norm (2).
  EXPECT_EQ(keys.size(), 2u + 3u + 12u * 14u + 2u);
  EXPECT_EQ(vit->pos_embed.sizes(), (std::vector<int64_t>{1, 1370, 384}));
  EXPECT_EQ(vit->blocks->ptr<BlockImpl>(0)->attn->qkv->weight.sizes(),
            (std::vector<int64_t>{1152, 384}));
  // On the native 37×37 grid the table is used as it is.
  EXPECT_TRUE(at::equal(vit->position_embedding(37, 37), vit->pos_embed));
}

TEST(DinoV2, RegistersWithoutLayerScaleAndSwiGLU) {
  DinoV2Config config = DinoV2Config::from_json(nlohmann::json{{"embed_dim", 32},
                                                               {"depth", 3},
                                                               {"num_heads", 2},
                                                               {"img_size", 70},
                                                               {"patch_size", 14},
                                                               {"num_register_tokens", 4},
                                                               {"init_values", nullptr},
                                                               {"ffn_layer", "swiglufused"}});
  DinoV2 vit(config);
  const auto keys = names(*vit);
  EXPECT_TRUE(keys.count("register_tokens"));
  EXPECT_FALSE(keys.count("blocks.0.ls1.gamma"));
  EXPECT_TRUE(keys.count("blocks.2.mlp.w12.weight"));
  EXPECT_TRUE(keys.count("blocks.2.mlp.w3.weight"));
  // SwiGLU hidden width: 2/3 of 4·32 = 85, rounded up to a multiple of 8.
  EXPECT_EQ(vit->blocks->ptr<BlockImpl>(0)->mlp->w3->weight.size(1), 88);

  c10::InferenceMode inference;
  const at::Tensor image = at::randn({2, 3, 28, 42});
  const at::Tensor tokens = vit->prepare_tokens(image);
  EXPECT_EQ(tokens.sizes(), (std::vector<int64_t>{2, 1 + 4 + 6, 32}));
  // Registers sit after the class token and get no position embedding.
  EXPECT_TRUE(at::equal(tokens.narrow(1, 1, 4), vit->register_tokens.expand({2, 4, 32})));
  const auto layers = vit->forward(image, {0, 2});
  ASSERT_EQ(layers.size(), 2u);
  EXPECT_EQ(layers[1].patch_tokens.sizes(), (std::vector<int64_t>{2, 6, 32}));
  EXPECT_EQ(layers[1].class_token.sizes(), (std::vector<int64_t>{2, 32}));
  EXPECT_THROW(vit->forward(image, {2, 1}), std::invalid_argument);
  EXPECT_THROW(vit->forward(at::randn({1, 3, 27, 42}), {0}), std::invalid_argument);
}

TEST(DinoV2, RejectsUnknownConfigKeys) {
  EXPECT_THROW(DinoV2Config::from_json(nlohmann::json{{"embed_dim", 32}, {"depht", 3}}),
               std::invalid_argument);
  EXPECT_THROW(DinoV2Config::from_json(nlohmann::json{{"embed_dim", 30}, {"num_heads", 4}}),
               std::invalid_argument);
  EXPECT_THROW(DinoV2Config::from_json(nlohmann::json{{"block_chunks", 4}}), std::invalid_argument);
  EXPECT_THROW(DinoV2Config::hub("dinov2_vitx14"), std::invalid_argument);
}

TEST(DinoV2, GroupedAttentionEqualsPlainAttention) {
  // 3,000 tokens: the score matrices exceed the budget, so heads run in groups.
  c10::InferenceMode inference;
  Attention attention(16, 4, true, true);
  const at::Tensor x = at::randn({1, 3000, 16});
  const at::Tensor qkv = attention->qkv(x).view({1, 3000, 3, 4, 4}).permute({2, 0, 3, 1, 4});
  const at::Tensor weights = at::softmax(at::matmul(qkv[0], qkv[1].transpose(-1, -2)) / 2.0, -1);
  const at::Tensor heads = at::matmul(weights, qkv[2]).transpose(1, 2).reshape({1, 3000, 16});
  EXPECT_TRUE(at::allclose(attention(x), attention->proj(heads), 1e-5, 1e-6));
}

}  // namespace
