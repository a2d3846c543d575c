#pragma once
// The --device option of every command, checked once: "cpu", "cuda" or "cuda:N".
#include <c10/core/Device.h>

#include <string>

namespace omnipoint::cli {

// std::invalid_argument with one line for a name LibTorch does not know and for CUDA when this
// build or machine has none (instead of LibTorch's multi-line trace at first use).
at::Device parse_device(const std::string& name);

}  // namespace omnipoint::cli
