#include "omnipoint/model/conv_stack.h"

#include <ATen/ATen.h>
#include <torch/nn/modules/activation.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/upsampling.h>
#include <nlohmann/json.hpp>

#include <stdexcept>

namespace omnipoint::model {

namespace {

torch::nn::Conv2d conv1x1(int64_t in, int64_t out) {
  return torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, 1));
}

torch::nn::Conv2d conv3x3_replicate(int64_t in, int64_t out) {
  return torch::nn::Conv2d(
      torch::nn::Conv2dOptions(in, out, 3).padding(1).padding_mode(torch::kReplicate));
}

// ×2 up-sampling followed by a 3×3 convolution (MoGe's Resampler).
torch::nn::Sequential resampler(const std::string& kind, int64_t in, int64_t out) {
  if (kind == "conv_transpose") {
    return torch::nn::Sequential(
        torch::nn::ConvTranspose2d(torch::nn::ConvTranspose2dOptions(in, out, 2).stride(2)),
        conv3x3_replicate(out, out));
  }
  if (kind == "bilinear") {
    return torch::nn::Sequential(
        torch::nn::Upsample(torch::nn::UpsampleOptions()
                                .scale_factor(std::vector<double>{2.0, 2.0})
                                .mode(torch::kBilinear)
                                .align_corners(false)),
        conv3x3_replicate(in, out));
  }
  throw std::invalid_argument("unsupported resampler '" + kind +
                              "' (expected conv_transpose or bilinear)");
}

// A JSON value that is either one value for all levels or a list of `levels` values.
template <typename T>
std::vector<T> per_level(const nlohmann::json& json, const std::string& key, size_t levels,
                         const std::string& name) {
  const nlohmann::json& value = json.at(key);
  std::vector<T> result;
  try {
    if (value.is_array()) {
      if (value.size() != levels)
        throw std::invalid_argument(name + ": '" + key + "' must have " + std::to_string(levels) +
                                    " entries");
      for (const auto& item : value) result.push_back(item.get<T>());
    } else {
      result.assign(levels, value.get<T>());
    }
  } catch (const nlohmann::json::exception&) {
    throw std::invalid_argument(name + ": '" + key + "' has the wrong type");
  }
  return result;
}

}  // namespace

}  // namespace omnipoint::model

// nlohmann support for optional channel counts (null = none).
namespace nlohmann {
template <>
struct adl_serializer<std::optional<int64_t>> {
  static void from_json(const json& j, std::optional<int64_t>& value) {
    value = j.is_null() ? std::nullopt : std::optional<int64_t>(j.get<int64_t>());
  }
};
}  // namespace nlohmann

namespace omnipoint::model {

ConvStackConfig ConvStackConfig::from_json(const nlohmann::json& json, const std::string& name) {
  if (!json.is_object()) throw std::invalid_argument(name + " config must be an object");
  for (const auto& [key, value] : json.items()) {
    if (key == "res_block_in_norm" || key == "res_block_hidden_norm") {
      if (!value.is_string() || value.get<std::string>() != "none")
        throw std::invalid_argument(name + ": " + key + " " + value.dump() +
                                    " is not supported (only \"none\")");
    } else if (key == "activation") {
      if (!value.is_string() || value.get<std::string>() != "relu")
        throw std::invalid_argument(name + ": activation " + value.dump() +
                                    " is not supported (only \"relu\")");
    } else if (key != "dim_in" && key != "dim_out" && key != "dim_res_blocks" &&
               key != "num_res_blocks" && key != "resamplers" &&
               key != "dim_times_res_block_hidden") {
      throw std::invalid_argument(name + ": unknown key '" + key + "'");
    }
  }
  if (!json.contains("dim_res_blocks") || !json["dim_res_blocks"].is_array() ||
      json["dim_res_blocks"].empty())
    throw std::invalid_argument(name + ": 'dim_res_blocks' must be a non-empty list");
  ConvStackConfig config;
  const size_t levels = json["dim_res_blocks"].size();
  config.dim_res_blocks = per_level<int64_t>(json, "dim_res_blocks", levels, name);
  config.dim_in = per_level<std::optional<int64_t>>(json, "dim_in", levels, name);
  config.dim_out = json.contains("dim_out")
                       ? per_level<std::optional<int64_t>>(json, "dim_out", levels, name)
                       : std::vector<std::optional<int64_t>>(levels);
  config.num_res_blocks = json.contains("num_res_blocks")
                              ? per_level<int64_t>(json, "num_res_blocks", levels, name)
                              : std::vector<int64_t>(levels, 1);
  config.resamplers = per_level<std::string>(json, "resamplers", levels - 1, name);
  if (json.contains("dim_times_res_block_hidden"))
    config.dim_times_res_block_hidden =
        per_level<int64_t>(json, "dim_times_res_block_hidden", 1, name)[0];
  config.validate(name);
  return config;
}

void ConvStackConfig::validate(const std::string& name) const {
  const size_t levels = dim_res_blocks.size();
  if (levels == 0 || dim_in.size() != levels || dim_out.size() != levels ||
      num_res_blocks.size() != levels || resamplers.size() != levels - 1) {
    throw std::invalid_argument(name + ": per-level lists must all have " + std::to_string(levels) +
                                " entries (resamplers one fewer)");
  }
  auto positive = [](const std::optional<int64_t>& d) { return !d || *d > 0; };
  for (size_t l = 0; l < levels; ++l) {
    if (dim_res_blocks[l] <= 0 || !positive(dim_in[l]) || !positive(dim_out[l]) ||
        num_res_blocks[l] < 0)
      throw std::invalid_argument(name +
                                  ": channel counts must be > 0 and num_res_blocks >= 0 (level " +
                                  std::to_string(l) + ")");
  }
  if (!dim_in[0]) throw std::invalid_argument(name + ": level 0 needs an input (dim_in[0])");
  if (dim_times_res_block_hidden <= 0)
    throw std::invalid_argument(name + ": dim_times_res_block_hidden must be > 0");
  for (const auto& kind : resamplers) {
    if (kind != "conv_transpose" && kind != "bilinear")
      throw std::invalid_argument(name + ": resampler '" + kind +
                                  "' is not supported (conv_transpose, bilinear)");
  }
}

ResidualConvBlockImpl::ResidualConvBlockImpl(int64_t channels, int64_t hidden_channels) {
  // Norms are "none" (identity) in MoGe-2; they keep their slots so the convs sit at 2 and 5.
  layers = register_module(
      "layers",
      torch::nn::Sequential(torch::nn::Identity(), torch::nn::ReLU(),
                            conv3x3_replicate(channels, hidden_channels), torch::nn::Identity(),
                            torch::nn::ReLU(), conv3x3_replicate(hidden_channels, channels)));
}

ConvStackImpl::ConvStackImpl(const ConvStackConfig& config) : config_(config) {
  config_.validate();
  const int64_t levels = config_.num_levels();
  input_blocks = register_module("input_blocks", torch::nn::ModuleList());
  res_blocks = register_module("res_blocks", torch::nn::ModuleList());
  resamplers = register_module("resamplers", torch::nn::ModuleList());
  output_blocks = register_module("output_blocks", torch::nn::ModuleList());
  for (int64_t l = 0; l < levels; ++l) {
    const int64_t dim = config_.dim_res_blocks[l];
    if (config_.dim_in[l])
      input_blocks->push_back(conv1x1(*config_.dim_in[l], dim));
    else
      input_blocks->push_back(torch::nn::Identity());
    torch::nn::Sequential blocks;
    for (int64_t k = 0; k < config_.num_res_blocks[l]; ++k)
      blocks->push_back(ResidualConvBlock(dim, dim * config_.dim_times_res_block_hidden));
    res_blocks->push_back(blocks);
    if (config_.dim_out[l])
      output_blocks->push_back(conv1x1(dim, *config_.dim_out[l]));
    else
      output_blocks->push_back(torch::nn::Identity());
    if (l + 1 < levels)
      resamplers->push_back(resampler(config_.resamplers[l], dim, config_.dim_res_blocks[l + 1]));
  }
}

std::vector<at::Tensor> ConvStackImpl::forward(const std::vector<at::Tensor>& inputs) {
  const int64_t levels = config_.num_levels();
  if (static_cast<int64_t>(inputs.size()) != levels)
    throw std::invalid_argument("conv stack expects " + std::to_string(levels) +
                                " level inputs, got " + std::to_string(inputs.size()));
  std::vector<at::Tensor> outputs;
  at::Tensor state;
  for (int64_t l = 0; l < levels; ++l) {
    if (inputs[l].defined()) {
      // A level without an input block adds its input unchanged (MoGe's nn.Identity).
      auto* input_block = input_blocks[l]->as<torch::nn::Conv2dImpl>();
      at::Tensor feature = input_block ? input_block->forward(inputs[l]) : inputs[l];
      state = state.defined() ? state + feature : feature;
    }
    if (!state.defined()) throw std::invalid_argument("conv stack: level 0 has no input");
    auto& blocks = *res_blocks->ptr<torch::nn::SequentialImpl>(l);
    if (!blocks.is_empty()) state = blocks.forward(state);
    auto* output_block = output_blocks[l]->as<torch::nn::Conv2dImpl>();
    outputs.push_back(output_block ? output_block->forward(state) : state);
    if (l + 1 < levels) state = resamplers->ptr<torch::nn::SequentialImpl>(l)->forward(state);
  }
  return outputs;
}

}  // namespace omnipoint::model
