#include "omnipoint/data/formats/depth_png.h"

#include <ATen/ATen.h>

#include <stdexcept>

#include "omnipoint/data/png_text.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"

namespace omnipoint::data {

at::Tensor read_uint16_png(const std::string& path, int64_t width, int64_t height) {
  const PngHeader header = read_png_header(io::read_file(path), path);
  if (header.bit_depth != 16 || header.colour_type != 0)
    throw std::runtime_error(path + ": expected a 16-bit grey depth PNG, got " +
                             png_pixel_format(header));
  if (header.width != width || header.height != height)
    throw std::runtime_error(path + ": the depth PNG is " + std::to_string(header.width) + "x" +
                             std::to_string(header.height) + " but the camera is " +
                             std::to_string(width) + "x" + std::to_string(height));
  const at::Tensor values = io::read_image_values(path);
  if (values.dim() != 2 || values.size(0) != height || values.size(1) != width)
    throw std::runtime_error(path + ": the depth PNG did not decode to " + std::to_string(width) +
                             "x" + std::to_string(height) + " values");
  return values.to(at::kFloat).contiguous();
}

}  // namespace omnipoint::data
