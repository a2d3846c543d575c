#include "cli/device.h"

#include <ATen/Context.h>

#include <stdexcept>

namespace omnipoint::cli {

at::Device parse_device(const std::string& name) {
  at::Device device = at::kCPU;
  try {
    device = at::Device(name);
  } catch (const std::exception&) {
    throw std::invalid_argument("--device " + name + ": expected cpu, cuda or cuda:N");
  }
  if (device.is_cuda() && !at::hasCUDA())
    throw std::invalid_argument("--device " + name +
                                ": this build has no CUDA (LibTorch without CUDA, or no GPU "
                                "visible); use --device cpu");
  if (!device.is_cpu() && !device.is_cuda())
    throw std::invalid_argument("--device " + name + ": expected cpu, cuda or cuda:N");
  return device;
}

model::Precision parse_precision(const std::string& name, at::Device device) {
  if (name == "auto") return model::default_precision(device.type());
  model::Precision precision{};
  try {
    precision = model::parse_precision(name);
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument("--precision " + name + ": expected auto, fp32, bf16 or fp16");
  }
  if (precision == model::Precision::kFloat16 && !device.is_cuda())
    throw std::invalid_argument("--precision fp16 needs --device cuda; on a CPU use bf16");
  return precision;
}

}  // namespace omnipoint::cli
