#pragma once
// Cameras from user input: a spec string (camera/camera.h) or a file holding cameras.
//   "PINHOLE 640 480 500 500 320 240"   a spec string, parsed as it is
//   path/to/cameras.txt                 its first camera; `path#ID` or `path:ID` picks by id
//   path/to/camera.json                 one JSON camera: ours, predict's camera.json as written,
//                                       or UniK3D's (camera/camera.h lists the forms)
#include <optional>
#include <string>

#include "omnipoint/camera/camera.h"

namespace omnipoint::io {

// Bad specs or files -> std::invalid_argument; unreadable files -> std::runtime_error; both
// name the spec or file and what was expected. `image_size` is the size of a camera whose
// spec has none (UniK3D's JSON: predict passes the image's); unused otherwise.
camera::Camera read_camera(const std::string& spec_or_path,
                           std::optional<camera::ImageSize> image_size = std::nullopt);

}  // namespace omnipoint::io
