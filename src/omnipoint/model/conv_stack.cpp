#include "omnipoint/model/conv_stack.h"

#include <ATen/ATen.h>
#include <torch/nn/modules/activation.h>
#include <torch/nn/modules/upsampling.h>
#include <nlohmann/json.hpp>

#include <functional>
#include <stdexcept>

#include "omnipoint/model/config_tables.h"
#include "omnipoint/model/layers.h"

namespace omnipoint::model {

namespace {

Conv2d conv1x1(int64_t in, int64_t out) {
  return Conv2d(torch::nn::Conv2dOptions(in, out, 1));
}

Conv2d conv3x3_replicate(int64_t in, int64_t out) {
  return Conv2d(torch::nn::Conv2dOptions(in, out, 3).padding(1).padding_mode(torch::kReplicate));
}

// ×2 up-sampling followed by a 3×3 convolution (MoGe's Resampler).
torch::nn::Sequential resampler(const std::string& kind, int64_t in, int64_t out) {
  if (kind == "conv_transpose") {
    return torch::nn::Sequential(
        ConvTranspose2d(torch::nn::ConvTranspose2dOptions(in, out, 2).stride(2)),
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

// `key`: one value for every level or a list of one per level (MoGe's ConvStack takes both),
// `fewer` levels less than dim_res_blocks (the resamplers sit between levels). `ok` is the
// check of each level's value.
template <typename V>
util::ConfigTable<ConvStackConfig>::Custom per_level_field(
    util::ConfigTable<ConvStackConfig>& table, const std::string& key,
    std::vector<V> ConvStackConfig::*member, util::ConfigCodec<V> item, std::size_t fewer,
    std::function<bool(const V&)> ok, const std::string& expected, const std::string& doc) {
  return table.custom(
      key,
      [=](const nlohmann::json& json, ConvStackConfig& config, const util::ConfigScope& scope) {
        const std::size_t levels = config.dim_res_blocks.size() - fewer;
        std::vector<V> values;
        if (json.is_array()) {
          if (json.size() != levels)
            scope.fail("expected " + std::to_string(levels) +
                       " entries (one per level) or one value for all, got " +
                       std::to_string(json.size()));
          for (std::size_t l = 0; l < levels; ++l)
            values.push_back(item.read(json[l], scope.index(l)));
        } else {
          values.assign(levels, item.read(json, scope));
        }
        config.*member = std::move(values);
      },
      [=](const ConvStackConfig& config, nlohmann::json& json) {
        json = nlohmann::json::array();
        for (const V& value : config.*member) item.write(value, util::config_json::append(json));
      },
      [=](const ConvStackConfig& config, const util::ConfigScope& scope) {
        const std::vector<V>& values = config.*member;
        for (std::size_t l = 0; l < values.size(); ++l)
          if (!ok(values[l])) scope.index(l).fail(expected);
      },
      doc);
}

}  // namespace

const util::ConfigTable<ConvStackConfig>& conv_stack_table() {
  static const util::ConfigTable<ConvStackConfig> table = [] {
    using Dims = std::optional<int64_t>;
    util::ConfigTable<ConvStackConfig> t;
    const auto channels = util::integer_codec<int64_t>();
    const auto optional_channels = util::nullable_codec(channels);
    const auto positive = [](const Dims& dims) { return !dims || *dims > 0; };
    // The number of levels: read first, the per-level keys follow it.
    t.custom(
         "dim_res_blocks",
         [list = util::list_codec(channels)](const nlohmann::json& json, ConvStackConfig& config,
                                             const util::ConfigScope& scope) {
           config.dim_res_blocks = list.read(json, scope);
           if (config.dim_res_blocks.empty()) scope.fail("expected a non-empty list, got []");
         },
         [](const ConvStackConfig& config, nlohmann::json& json) { json = config.dim_res_blocks; },
         [](const ConvStackConfig& config, const util::ConfigScope& scope) {
           for (std::size_t l = 0; l < config.dim_res_blocks.size(); ++l)
             if (config.dim_res_blocks[l] <= 0) scope.index(l).fail("must be positive");
         },
         "the state's channels per level")
        .required("required (a non-empty list: the state's channels per level)");
    per_level_field<Dims>(t, "dim_in", &ConvStackConfig::dim_in, optional_channels, 0, positive,
                          "must be positive or null", "a level's input channels; null: none")
        .required();
    per_level_field<Dims>(t, "dim_out", &ConvStackConfig::dim_out, optional_channels, 0, positive,
                          "must be positive or null",
                          "a level's output channels; null (default): the state is the output")
        .if_absent([](ConvStackConfig& config) {
          config.dim_out.assign(config.dim_res_blocks.size(), std::nullopt);
        });
    per_level_field<int64_t>(
        t, "num_res_blocks", &ConvStackConfig::num_res_blocks, channels, 0,
        [](const int64_t& n) { return n >= 0; }, "must be >= 0", "residual blocks per level")
        .if_absent([](ConvStackConfig& config) {
          config.num_res_blocks.assign(config.dim_res_blocks.size(), 1);
        });
    per_level_field<std::string>(
        t, "resamplers", &ConvStackConfig::resamplers, util::string_codec(), 1,
        [](const std::string& kind) { return kind == "conv_transpose" || kind == "bilinear"; },
        "is not supported (conv_transpose, bilinear)", "between levels")
        .required();
    // One value, or a list of one (MoGe's form).
    t.custom(
        "dim_times_res_block_hidden",
        [channels](const nlohmann::json& json, ConvStackConfig& config,
                   const util::ConfigScope& scope) {
          if (json.is_array() && json.size() != 1)
            scope.fail("expected one value, got " + util::config_json::short_text(json));
          config.dim_times_res_block_hidden =
              json.is_array() ? channels.read(json[0], scope.index(0)) : channels.read(json, scope);
        },
        [](const ConvStackConfig& config, nlohmann::json& json) {
          json = config.dim_times_res_block_hidden;
        },
        [](const ConvStackConfig& config, const util::ConfigScope& scope) {
          if (config.dim_times_res_block_hidden <= 0) scope.fail("must be positive");
        },
        "hidden channels of a residual block, per state channel");
    t.constant("res_block_in_norm", "none");
    t.constant("res_block_hidden_norm", "none");
    t.constant("activation", "relu", /*written=*/false);
    t.rule([](const ConvStackConfig& config, const util::ConfigScope& scope) {
      const std::size_t levels = config.dim_res_blocks.size();
      if (levels == 0 || config.dim_in.size() != levels || config.dim_out.size() != levels ||
          config.num_res_blocks.size() != levels || config.resamplers.size() != levels - 1)
        scope.fail("per-level lists must all have " + std::to_string(levels) +
                   " entries (resamplers one fewer)");
      if (!config.dim_in[0]) scope.key("dim_in").index(0).fail("level 0 needs an input");
    });
    return t;
  }();
  return table;
}

void ConvStackConfig::validate(const std::string& name) const {
  util::check_config(conv_stack_table(), *this, name);
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
      auto* input_block = input_blocks[l]->as<Conv2dImpl>();
      at::Tensor feature = input_block ? input_block->forward(inputs[l]) : inputs[l];
      state = state.defined() ? state + feature : feature;
    }
    if (!state.defined()) throw std::invalid_argument("conv stack: level 0 has no input");
    auto& blocks = *res_blocks->ptr<torch::nn::SequentialImpl>(l);
    if (!blocks.is_empty()) state = blocks.forward(state);
    auto* output_block = output_blocks[l]->as<Conv2dImpl>();
    outputs.push_back(output_block ? output_block->forward(state) : state);
    if (l + 1 < levels) state = resamplers->ptr<torch::nn::SequentialImpl>(l)->forward(state);
  }
  return outputs;
}

}  // namespace omnipoint::model
