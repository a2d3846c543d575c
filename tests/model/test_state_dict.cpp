#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/normalization.h>

#include <string>

#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/state_dict.h"

using omnipoint::model::load_state_dict;
using omnipoint::model::LoadMode;
using omnipoint::model::LoadReport;
using omnipoint::model::state_dict;

namespace {

// A small module tree with nested names, a parameter, and a buffer.
struct BlockImpl : torch::nn::Module {
  BlockImpl() {
    norm = register_module("norm", torch::nn::LayerNorm(torch::nn::LayerNormOptions({8})));
    fc = register_module("fc", torch::nn::Linear(8, 4));
    gamma = register_parameter("gamma", at::ones({4}));
  }
  torch::nn::LayerNorm norm{nullptr};
  torch::nn::Linear fc{nullptr};
  at::Tensor gamma;
};
TORCH_MODULE(Block);

struct NetImpl : torch::nn::Module {
  NetImpl() {
    proj = register_module("proj", torch::nn::Conv2d(torch::nn::Conv2dOptions(3, 8, 2)));
    block = register_module("block", Block());
    mean = register_buffer("image_mean", at::full({1, 3, 1, 1}, 0.5));
    steps = register_buffer("steps", at::zeros({1}, at::kLong));
  }
  torch::nn::Conv2d proj{nullptr};
  Block block{nullptr};
  at::Tensor mean, steps;
};
TORCH_MODULE(Net);

const std::vector<std::string> kNames = {"block.fc.bias",   "block.fc.weight",   "block.gamma",
                                         "block.norm.bias", "block.norm.weight", "image_mean",
                                         "proj.bias",       "proj.weight",       "steps"};

std::map<std::string, at::Tensor> random_weights(const Net& net) {
  std::map<std::string, at::Tensor> out;
  for (const auto& [name, t] : state_dict(*net)) {
    out[name] = at::isFloatingType(t.scalar_type()) ? at::randn_like(t) : at::randint_like(t, 100);
  }
  return out;
}

std::string strict_error(Net& net, const std::map<std::string, at::Tensor>& tensors) {
  try {
    load_state_dict(*net, tensors, LoadMode::kStrict);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(StateDict, NamesAreDottedParametersAndBuffers) {
  Net net;
  std::vector<std::string> names;
  for (const auto& [name, t] : state_dict(*net)) names.push_back(name);
  EXPECT_EQ(names, kNames);
  EXPECT_FALSE(state_dict(*net).at("proj.weight").requires_grad());
}

TEST(StateDict, StrictLoadCopiesEverything) {
  Net net;
  const auto weights = random_weights(net);
  const LoadReport report = load_state_dict(*net, weights, LoadMode::kStrict);
  EXPECT_EQ(report.loaded, kNames);
  EXPECT_TRUE(report.missing.empty() && report.unexpected.empty() && report.mismatched.empty());
  for (const auto& [name, t] : state_dict(*net))
    EXPECT_TRUE(at::equal(t, weights.at(name))) << name;
  EXPECT_TRUE(net->proj->weight.requires_grad());  // still a trainable parameter
}

TEST(StateDict, StrictLoadListsEveryProblemAndChangesNothing) {
  Net net;
  const auto before = state_dict(*net);
  std::map<std::string, at::Tensor> snapshot;
  for (const auto& [name, t] : before) snapshot[name] = t.clone();

  auto weights = random_weights(net);
  weights.erase("block.gamma");
  weights.erase("image_mean");
  weights["block.extra"] = at::zeros({2});
  weights["proj.weight"] = at::zeros({8, 3, 3, 3});
  const std::string message = strict_error(net, weights);
  EXPECT_NE(message.find("2 missing (block.gamma, image_mean)"), std::string::npos) << message;
  EXPECT_NE(message.find("1 unexpected (block.extra)"), std::string::npos) << message;
  EXPECT_NE(message.find("1 mismatched (proj.weight: given [8, 3, 3, 3], module has [8, 3, 2, 2])"),
            std::string::npos)
      << message;
  for (const auto& [name, t] : state_dict(*net))
    EXPECT_TRUE(at::equal(t, snapshot.at(name))) << name;
}

TEST(StateDict, StrictErrorTruncatesLongLists) {
  Net net;
  auto weights = random_weights(net);
  for (int i = 0; i < 25; ++i) weights["extra." + std::to_string(i)] = at::zeros({1});
  const std::string message = strict_error(net, weights);
  EXPECT_NE(message.find("25 unexpected (extra.0, extra.1,"), std::string::npos) << message;
  EXPECT_NE(message.find(", ... and 15 more)"), std::string::npos) << message;
  EXPECT_EQ(message.find("extra.24"), std::string::npos) << message;
}

TEST(StateDict, PartialLoadTakesWhatMatches) {
  Net net;
  const at::Tensor old_gamma = net->block->gamma.clone();
  const at::Tensor old_proj = net->proj->weight.clone();
  auto weights = random_weights(net);
  weights.erase("block.gamma");
  weights["proj.weight"] = at::zeros({8, 3, 3, 3});
  weights["head.weight"] = at::zeros({1});
  const LoadReport report = load_state_dict(*net, weights, LoadMode::kPartial);
  EXPECT_EQ(report.missing, std::vector<std::string>{"block.gamma"});
  EXPECT_EQ(report.unexpected, std::vector<std::string>{"head.weight"});
  EXPECT_EQ(report.mismatched, std::vector<std::string>{"proj.weight"});
  EXPECT_EQ(report.loaded.size(), kNames.size() - 2);
  EXPECT_TRUE(at::equal(net->block->gamma, old_gamma));
  EXPECT_TRUE(at::equal(net->proj->weight, old_proj));
  EXPECT_TRUE(at::equal(net->block->fc->weight, weights.at("block.fc.weight")));
}

TEST(StateDict, LoadKeepsTheModuleDtype) {
  Net net;
  net->to(at::kDouble);                  // LibTorch converts every tensor, the integer buffer too
  auto weights = random_weights(Net());  // float32 and int64 source
  load_state_dict(*net, weights, LoadMode::kStrict);
  EXPECT_EQ(net->proj->weight.scalar_type(), at::kDouble);
  EXPECT_TRUE(at::equal(net->proj->weight, weights.at("proj.weight").to(at::kDouble)));
  EXPECT_TRUE(at::equal(net->steps, weights.at("steps").to(at::kDouble)));
}

TEST(StateDict, ModuleRoundTripsBitExactlyThroughSafetensors) {
  Net source, target;
  const std::string bytes =
      omnipoint::io::encode_safetensors(state_dict(*source), {{"format", "test"}});
  const auto file = omnipoint::io::parse_safetensors(bytes.data(), bytes.size(), "module");
  load_state_dict(*target, file.tensors, LoadMode::kStrict);
  const auto a = state_dict(*source), b = state_dict(*target);
  for (const auto& [name, t] : a) {
    ASSERT_EQ(t.scalar_type(), b.at(name).scalar_type()) << name;
    EXPECT_EQ(0, std::memcmp(t.data_ptr(), b.at(name).data_ptr(), t.numel() * t.element_size()))
        << name;
  }
}
