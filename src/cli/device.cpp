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

}  // namespace omnipoint::cli
