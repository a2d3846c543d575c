#pragma once
// File-name helpers of the readers' format dispatch.
#include <string>

namespace omnipoint::io {

// The extension of `path` in lower case (".npy").
std::string lower_extension(const std::string& path);

}  // namespace omnipoint::io
