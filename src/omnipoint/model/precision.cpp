#include "omnipoint/model/precision.h"

#include <ATen/autocast_mode.h>

#include <stdexcept>

namespace omnipoint::model {

Precision parse_precision(const std::string& name) {
  if (name == "fp32") return Precision::kFloat32;
  if (name == "bf16") return Precision::kBFloat16;
  if (name == "fp16") return Precision::kFloat16;
  throw std::invalid_argument("unknown precision '" + name + "' (expected fp32, bf16 or fp16)");
}

std::string precision_name(Precision precision) {
  switch (precision) {
    case Precision::kBFloat16:
      return "bf16";
    case Precision::kFloat16:
      return "fp16";
    case Precision::kFloat32:
      break;
  }
  return "fp32";
}

bool cpu_has_native_bf16() {
#if defined(__x86_64__) && defined(__GNUC__)
  return __builtin_cpu_supports("avx512bf16") != 0;
#else
  return false;
#endif
}

Precision default_precision(c10::DeviceType device) {
  return device == c10::DeviceType::CPU && cpu_has_native_bf16() ? Precision::kBFloat16
                                                                 : Precision::kFloat32;
}

AutocastScope::AutocastScope(Precision precision, c10::DeviceType device) {
  if (precision == Precision::kFloat32) return;
  const bool cuda = device == c10::DeviceType::CUDA;
  if (!cuda && device != c10::DeviceType::CPU)
    throw std::invalid_argument("precision " + precision_name(precision) +
                                " is supported on CPU and CUDA devices only");
  if (precision == Precision::kFloat16 && !cuda)
    throw std::invalid_argument("precision fp16 needs a CUDA device (on a CPU use bf16)");
  active_ = true;
  cpu_enabled_ = at::autocast::is_cpu_enabled();
  gpu_enabled_ = at::autocast::is_enabled();
  cpu_dtype_ = at::autocast::get_autocast_cpu_dtype();
  gpu_dtype_ = at::autocast::get_autocast_gpu_dtype();
  const c10::ScalarType dtype = precision == Precision::kFloat16 ? at::kHalf : at::kBFloat16;
  if (cuda) {
    at::autocast::set_autocast_gpu_dtype(dtype);
    at::autocast::set_enabled(true);
  } else {
    at::autocast::set_autocast_cpu_dtype(dtype);
    at::autocast::set_cpu_enabled(true);
  }
  at::autocast::increment_nesting();
}

AutocastScope::~AutocastScope() {
  if (!active_) return;
  // The outermost scope drops the casts of the weights it cached.
  if (at::autocast::decrement_nesting() == 0) at::autocast::clear_cache();
  at::autocast::set_cpu_enabled(cpu_enabled_);
  at::autocast::set_enabled(gpu_enabled_);
  at::autocast::set_autocast_cpu_dtype(cpu_dtype_);
  at::autocast::set_autocast_gpu_dtype(gpu_dtype_);
}

AutocastOff::AutocastOff()
    : cpu_enabled_(at::autocast::is_cpu_enabled()), gpu_enabled_(at::autocast::is_enabled()) {
  at::autocast::set_cpu_enabled(false);
  at::autocast::set_enabled(false);
}

AutocastOff::~AutocastOff() {
  at::autocast::set_cpu_enabled(cpu_enabled_);
  at::autocast::set_enabled(gpu_enabled_);
}

}  // namespace omnipoint::model
