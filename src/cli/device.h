#pragma once
// The --device option of every command, checked once: "cpu", "cuda" or "cuda:N"; and the
// --precision option of the commands that run a network.
#include <c10/core/Device.h>

#include <string>

#include "omnipoint/model/precision.h"

namespace omnipoint::cli {

// std::invalid_argument with one line for a name LibTorch does not know and for CUDA when this
// build or machine has none (instead of LibTorch's multi-line trace at first use).
at::Device parse_device(const std::string& name);

// auto (model::default_precision: bf16 on a CPU with native bf16, else fp32), fp32, bf16 (CPU
// or CUDA) or fp16 (CUDA); std::invalid_argument with one line otherwise.
inline constexpr const char* kPrecisionHelp =
    "Network precision: auto (bf16 on a CPU with native bf16, else fp32), fp32, bf16 (about "
    "twice as fast for large models on such CPUs, points within ~1 % of fp32) or fp16 (CUDA)";
model::Precision parse_precision(const std::string& name, at::Device device);

}  // namespace omnipoint::cli
