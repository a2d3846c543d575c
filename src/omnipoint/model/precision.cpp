#include "omnipoint/model/precision.h"

#include <ATen/autocast_mode.h>
#include <torch/version.h>

#include <stdexcept>

namespace omnipoint::model {
namespace {

// LibTorch 2.4 keyed autocast's state by device type and deprecated the per-device functions
// that 1.13 (Debian's) has; these four are the one place that knows both.
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
bool autocast_enabled(c10::DeviceType device) {
  return at::autocast::is_autocast_enabled(device);
}
void set_autocast_enabled(c10::DeviceType device, bool enabled) {
  at::autocast::set_autocast_enabled(device, enabled);
}
c10::ScalarType autocast_dtype(c10::DeviceType device) {
  return at::autocast::get_autocast_dtype(device);
}
void set_autocast_dtype(c10::DeviceType device, c10::ScalarType dtype) {
  at::autocast::set_autocast_dtype(device, dtype);
}
#else
bool autocast_enabled(c10::DeviceType device) {
  return device == c10::DeviceType::CUDA ? at::autocast::is_enabled()
                                         : at::autocast::is_cpu_enabled();
}
void set_autocast_enabled(c10::DeviceType device, bool enabled) {
  if (device == c10::DeviceType::CUDA)
    at::autocast::set_enabled(enabled);
  else
    at::autocast::set_cpu_enabled(enabled);
}
c10::ScalarType autocast_dtype(c10::DeviceType device) {
  return device == c10::DeviceType::CUDA ? at::autocast::get_autocast_gpu_dtype()
                                         : at::autocast::get_autocast_cpu_dtype();
}
void set_autocast_dtype(c10::DeviceType device, c10::ScalarType dtype) {
  if (device == c10::DeviceType::CUDA)
    at::autocast::set_autocast_gpu_dtype(dtype);
  else
    at::autocast::set_autocast_cpu_dtype(dtype);
}
#endif

constexpr c10::DeviceType kCpu = c10::DeviceType::CPU;
constexpr c10::DeviceType kCuda = c10::DeviceType::CUDA;

}  // namespace

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
  cpu_enabled_ = autocast_enabled(kCpu);
  gpu_enabled_ = autocast_enabled(kCuda);
  cpu_dtype_ = autocast_dtype(kCpu);
  gpu_dtype_ = autocast_dtype(kCuda);
  set_autocast_dtype(device, precision == Precision::kFloat16 ? at::kHalf : at::kBFloat16);
  set_autocast_enabled(device, true);
  at::autocast::increment_nesting();
}

AutocastScope::~AutocastScope() {
  if (!active_) return;
  // The outermost scope drops the casts of the weights it cached.
  if (at::autocast::decrement_nesting() == 0) at::autocast::clear_cache();
  set_autocast_enabled(kCpu, cpu_enabled_);
  set_autocast_enabled(kCuda, gpu_enabled_);
  set_autocast_dtype(kCpu, cpu_dtype_);
  set_autocast_dtype(kCuda, gpu_dtype_);
}

AutocastOff::AutocastOff()
    : cpu_enabled_(autocast_enabled(kCpu)), gpu_enabled_(autocast_enabled(kCuda)) {
  set_autocast_enabled(kCpu, false);
  set_autocast_enabled(kCuda, false);
}

AutocastOff::~AutocastOff() {
  set_autocast_enabled(kCpu, cpu_enabled_);
  set_autocast_enabled(kCuda, gpu_enabled_);
}

}  // namespace omnipoint::model
