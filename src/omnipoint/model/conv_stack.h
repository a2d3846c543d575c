#pragma once
// MoGe-2's ConvStack: the multi-level convolutional decoder used for the neck and the heads.
//
// Level l works at 2^l times the token grid. Per level: an optional 1×1 input block adds the
// level's input to the running state, residual blocks refine it, an optional 1×1 output
// block reads it out, and a resampler doubles its resolution for the next level
// (fixtures README §1.5). Names equal MoGe-2's: input_blocks.l, res_blocks.l.k.layers.{2,5},
// resamplers.l.{0,1}, output_blocks.l.
#include <ATen/core/Tensor.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/container/modulelist.h>
#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/pimpl.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace omnipoint::model {

// Read and written as MoGe-2's ConvStack keywords by conv_stack_table() (model/config_tables.h):
// `dim_in`, `dim_out`, `num_res_blocks` and `resamplers` may be one value for all levels, as in
// MoGe; only norms "none" and activation "relu" (what MoGe-2 uses) are supported.
struct ConvStackConfig {
  std::vector<std::optional<int64_t>> dim_in;   // per level; none: the level takes no input
  std::vector<int64_t> dim_res_blocks;          // the state's channels per level
  std::vector<std::optional<int64_t>> dim_out;  // per level; none: the state is the output
  std::vector<int64_t> num_res_blocks;          // per level
  std::vector<std::string> resamplers;          // levels − 1 of "conv_transpose", "bilinear"
  int64_t dim_times_res_block_hidden = 1;

  int64_t num_levels() const { return static_cast<int64_t>(dim_res_blocks.size()); }
  // The table's checks; std::invalid_argument "NAME: KEY: problem".
  void validate(const std::string& name = "conv stack") const;
};

// y = x + conv5(relu(conv2(relu(x)))), 3×3 convolutions with replicate padding.
class ResidualConvBlockImpl : public torch::nn::Module {
 public:
  ResidualConvBlockImpl(int64_t channels, int64_t hidden_channels);
  at::Tensor forward(const at::Tensor& x) { return x + layers->forward(x); }
  torch::nn::Sequential layers{nullptr};  // [in norm, relu, conv, hidden norm, relu, conv]
};
TORCH_MODULE(ResidualConvBlock);

class ConvStackImpl : public torch::nn::Module {
 public:
  explicit ConvStackImpl(const ConvStackConfig& config);

  // `inputs[l]` feeds level l (undefined: no input there); returns every level's output.
  std::vector<at::Tensor> forward(const std::vector<at::Tensor>& inputs);

  const ConvStackConfig& config() const { return config_; }

  torch::nn::ModuleList input_blocks{nullptr};
  torch::nn::ModuleList res_blocks{nullptr};
  torch::nn::ModuleList resamplers{nullptr};
  torch::nn::ModuleList output_blocks{nullptr};

 private:
  ConvStackConfig config_;
};
TORCH_MODULE(ConvStack);

}  // namespace omnipoint::model
