#pragma once
// Reduced-precision inference. bf16 (CPU or CUDA) and fp16 (CUDA) run the network's matrix
// products and convolutions in the 16-bit type through LibTorch's autocast; the models keep
// what is numerically sensitive in the input's precision themselves: the residual stream and
// its layer norms, the resize of the heads to the image and what follows it, the metric-scale
// head (AutocastOff). So everything after the network is fp32. (The attention's softmax runs in
// bf16 as autocast leaves it: in fp32 it cost ViT-L 1.6 s and moved no point measurably.)
#include <c10/core/DeviceType.h>
#include <c10/core/ScalarType.h>

#include <string>

namespace omnipoint::model {

enum class Precision { kFloat32, kBFloat16, kFloat16 };

// "fp32", "bf16" or "fp16"; std::invalid_argument naming the valid ones otherwise.
Precision parse_precision(const std::string& name);
std::string precision_name(Precision precision);

// Whether this CPU computes bf16 natively (AVX-512 BF16), where bf16 pays.
bool cpu_has_native_bf16();
// The commands' default ("auto"): bf16 on a CPU with native bf16, fp32 elsewhere (CUDA
// included). On the synthetic benchmark bf16 moves the bundled model's scores by at most
// 0.08 points Rel (docs/PERFORMANCE.md).
Precision default_precision(c10::DeviceType device);

// Autocast to `precision` on `device` for the scope's lifetime (fp32: nothing changes); the
// previous state comes back after it. std::invalid_argument for fp16 on a CPU.
class AutocastScope {
 public:
  AutocastScope(Precision precision, c10::DeviceType device);
  ~AutocastScope();
  AutocastScope(const AutocastScope&) = delete;
  AutocastScope& operator=(const AutocastScope&) = delete;

 private:
  bool active_ = false;
  bool cpu_enabled_ = false, gpu_enabled_ = false;
  c10::ScalarType cpu_dtype_{}, gpu_dtype_{};
};

// Autocast off for the scope's lifetime (a part that must stay in full precision).
class AutocastOff {
 public:
  AutocastOff();
  ~AutocastOff();
  AutocastOff(const AutocastOff&) = delete;
  AutocastOff& operator=(const AutocastOff&) = delete;

 private:
  bool cpu_enabled_, gpu_enabled_;
};

}  // namespace omnipoint::model
