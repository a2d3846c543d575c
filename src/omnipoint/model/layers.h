#pragma once
// The network's weighted layers: Linear, Conv2d and ConvTranspose2d with torch::nn's names
// (weight, bias), shapes, options and forward, whose random initialisation can be left out.
// LibTorch's own modules fill every parameter randomly as they are constructed; a network built
// only to be loaded from a checkpoint would fill, and first touch, all of its memory (1.2 GB for
// ViT-L) just to overwrite it: over a second per process (docs/PERFORMANCE.md "Single image").
// Under a SkipParameterInit scope these layers allocate their parameters and leave them
// unfilled; elsewhere LibTorch's module initialises them, so a fresh network draws the same
// numbers in the same order as one built of torch::nn modules.
#include <ATen/core/Tensor.h>
#include <torch/nn/cloneable.h>
#include <torch/nn/options/conv.h>
#include <torch/nn/options/linear.h>
#include <torch/nn/pimpl.h>

namespace omnipoint::model {

// While one lives, the layers this thread constructs are not initialised: for networks whose
// every parameter is then loaded (load_state_dict in strict mode).
class SkipParameterInit {
 public:
  SkipParameterInit();
  ~SkipParameterInit();
  SkipParameterInit(const SkipParameterInit&) = delete;
  SkipParameterInit& operator=(const SkipParameterInit&) = delete;

 private:
  bool outer_;
};

class LinearImpl : public torch::nn::Cloneable<LinearImpl> {
 public:
  LinearImpl(int64_t in_features, int64_t out_features)
      : LinearImpl(torch::nn::LinearOptions(in_features, out_features)) {}
  explicit LinearImpl(const torch::nn::LinearOptions& options);
  void reset() override;
  at::Tensor forward(const at::Tensor& input);

  torch::nn::LinearOptions options;
  at::Tensor weight, bias;
};
TORCH_MODULE(Linear);

// Padding by numbers (not "same"/"valid"); padding_mode zeros or a torch::nn::functional::pad
// mode (replicate, reflect, circular).
class Conv2dImpl : public torch::nn::Cloneable<Conv2dImpl> {
 public:
  explicit Conv2dImpl(const torch::nn::Conv2dOptions& options);
  void reset() override;
  at::Tensor forward(const at::Tensor& input);

  torch::nn::Conv2dOptions options;
  at::Tensor weight, bias;
};
TORCH_MODULE(Conv2d);

class ConvTranspose2dImpl : public torch::nn::Cloneable<ConvTranspose2dImpl> {
 public:
  explicit ConvTranspose2dImpl(const torch::nn::ConvTranspose2dOptions& options);
  void reset() override;
  at::Tensor forward(const at::Tensor& input);

  torch::nn::ConvTranspose2dOptions options;
  at::Tensor weight, bias;
};
TORCH_MODULE(ConvTranspose2d);

}  // namespace omnipoint::model
