#include "omnipoint/io/camera_file.h"

#include <filesystem>
#include <stdexcept>

#include "omnipoint/io/atomic_file.h"

namespace omnipoint::io {

camera::Camera read_camera(const std::string& spec_or_path,
                           std::optional<camera::ImageSize> image_size) {
  namespace fs = std::filesystem;
  if (camera::is_camera_line(spec_or_path)) return camera::parse_camera(spec_or_path, image_size);
  if (fs::is_regular_file(spec_or_path))
    return camera::parse_camera_file(read_file(spec_or_path), spec_or_path, "", image_size);
  const auto separator = spec_or_path.find_last_of("#:");
  if (separator != std::string::npos && fs::is_regular_file(spec_or_path.substr(0, separator))) {
    const std::string path = spec_or_path.substr(0, separator);
    return camera::parse_camera_file(read_file(path), path, spec_or_path.substr(separator + 1),
                                     image_size);
  }
  throw std::runtime_error("camera spec '" + spec_or_path +
                           "' is not a camera line ('MODEL WIDTH HEIGHT PARAMS...'), a JSON "
                           "object, or an existing file");
}

}  // namespace omnipoint::io
