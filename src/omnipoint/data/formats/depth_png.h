#pragma once
// 16-bit depth PNGs (KITTI-360 proj_depth, and the like): the stored integers, checked to be a
// 16-bit single-channel image of the camera's size before they are decoded.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>

namespace omnipoint::data {

// The values of a 16-bit grey PNG as float32 (H, W) (exact). Another pixel format (8-bit,
// RGB, ...) or a size other than width x height -> std::runtime_error naming the file and
// what it holds; unreadable or corrupt -> std::runtime_error naming it.
at::Tensor read_uint16_png(const std::string& path, int64_t width, int64_t height);

}  // namespace omnipoint::data
