#include "omnipoint/model/layers.h"

#include <ATen/ATen.h>
#include <ATen/PadNd.h>
#include <torch/nn/functional/linear.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>

#include <stdexcept>
#include <vector>

namespace omnipoint::model {
namespace {

thread_local bool skip_parameter_init = false;

// `name` registered on `module`: LibTorch's initialised tensor, or `shape` left unfilled.
at::Tensor parameter(torch::nn::Module& module, const char* name, const at::Tensor& initialised,
                     at::IntArrayRef shape) {
  return module.register_parameter(name, skip_parameter_init ? at::empty(shape) : initialised);
}

// A convolution's weight and bias (bias: when options.bias()), from LibTorch's module of the
// same options when initialising. Weight shape: (out, in / groups, kh, kw), transposed
// (in, out / groups, kh, kw).
template <typename TorchConv, typename Options>
void register_conv(torch::nn::Module& module, const Options& options, bool transposed,
                   at::Tensor& weight, at::Tensor& bias) {
  const int64_t groups = options.groups();
  if (options.in_channels() % groups != 0 || options.out_channels() % groups != 0)
    throw std::invalid_argument("convolution: channels not divisible by groups");
  std::vector<int64_t> shape =
      transposed ? std::vector<int64_t>{options.in_channels(), options.out_channels() / groups}
                 : std::vector<int64_t>{options.out_channels(), options.in_channels() / groups};
  shape.insert(shape.end(), options.kernel_size()->begin(), options.kernel_size()->end());
  std::shared_ptr<TorchConv> initialised;
  if (!skip_parameter_init) initialised = std::make_shared<TorchConv>(options);
  weight = parameter(module, "weight", initialised ? initialised->weight : at::Tensor(), shape);
  if (options.bias())
    bias = parameter(module, "bias", initialised ? initialised->bias : at::Tensor(),
                     {options.out_channels()});
  else
    module.register_parameter("bias", at::Tensor(), /*requires_grad=*/false);
}

const torch::ExpandingArray<2>& numeric_padding(const torch::nn::Conv2dOptions& options) {
  const auto* padding = c10::get_if<torch::ExpandingArray<2>>(&options.padding());
  if (padding == nullptr)
    throw std::invalid_argument("Conv2d: padding must be numbers (not \"same\" or \"valid\")");
  return *padding;
}

}  // namespace

SkipParameterInit::SkipParameterInit() : outer_(skip_parameter_init) {
  skip_parameter_init = true;
}
SkipParameterInit::~SkipParameterInit() {
  skip_parameter_init = outer_;
}

LinearImpl::LinearImpl(const torch::nn::LinearOptions& options_) : options(options_) {
  reset();
}

void LinearImpl::reset() {
  std::shared_ptr<torch::nn::LinearImpl> initialised;
  if (!skip_parameter_init) initialised = std::make_shared<torch::nn::LinearImpl>(options);
  weight = parameter(*this, "weight", initialised ? initialised->weight : at::Tensor(),
                     {options.out_features(), options.in_features()});
  if (options.bias())
    bias = parameter(*this, "bias", initialised ? initialised->bias : at::Tensor(),
                     {options.out_features()});
  else
    register_parameter("bias", at::Tensor(), /*requires_grad=*/false);
}

// torch::nn::Linear's own computation (a matmul and an added bias for batched inputs), which is
// not at::linear's: the same outputs, to the bit, as networks built of torch::nn::Linear.
at::Tensor LinearImpl::forward(const at::Tensor& input) {
  return torch::nn::functional::linear(input, weight, bias);
}

Conv2dImpl::Conv2dImpl(const torch::nn::Conv2dOptions& options_) : options(options_) {
  reset();
}

void Conv2dImpl::reset() {
  numeric_padding(options);
  register_conv<torch::nn::Conv2dImpl>(*this, options, /*transposed=*/false, weight, bias);
}

at::Tensor Conv2dImpl::forward(const at::Tensor& input) {
  const torch::ExpandingArray<2>& padding = numeric_padding(options);
  const auto& mode = options.padding_mode();
  if (c10::get_if<torch::enumtype::kZeros>(&mode) != nullptr)
    return at::conv2d(input, weight, bias, options.stride(), padding, options.dilation(),
                      options.groups());
  // As torch::nn::Conv2d: pad first (last dimension first), then convolve without padding.
  const at::padding_mode pad_mode =
      c10::get_if<torch::enumtype::kReplicate>(&mode) != nullptr ? at::padding_mode::replicate
      : c10::get_if<torch::enumtype::kReflect>(&mode) != nullptr ? at::padding_mode::reflect
                                                                 : at::padding_mode::circular;
  const std::vector<int64_t> pad = {(*padding)[1], (*padding)[1], (*padding)[0], (*padding)[0]};
  const at::Tensor padded = at::_pad_enum(input, pad, static_cast<int64_t>(pad_mode), c10::nullopt);
  return at::conv2d(padded, weight, bias, options.stride(), /*padding=*/at::IntArrayRef{0, 0},
                    options.dilation(), options.groups());
}

ConvTranspose2dImpl::ConvTranspose2dImpl(const torch::nn::ConvTranspose2dOptions& options_)
    : options(options_) {
  reset();
}

void ConvTranspose2dImpl::reset() {
  if (c10::get_if<torch::enumtype::kZeros>(&options.padding_mode()) == nullptr)
    throw std::invalid_argument("ConvTranspose2d: only zero padding");
  register_conv<torch::nn::ConvTranspose2dImpl>(*this, options, /*transposed=*/true, weight, bias);
}

at::Tensor ConvTranspose2dImpl::forward(const at::Tensor& input) {
  return at::conv_transpose2d(input, weight, bias, options.stride(), options.padding(),
                              options.output_padding(), options.groups(), options.dilation());
}

}  // namespace omnipoint::model
