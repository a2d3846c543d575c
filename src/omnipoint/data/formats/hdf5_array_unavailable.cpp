// hdf5_array.h in a build without libhdf5 (OMNIPOINT_WITH_HDF5 off or not found).
#include <ATen/core/Tensor.h>

#include <stdexcept>

#include "omnipoint/data/formats/hdf5_array.h"

namespace omnipoint::data::formats {

bool hdf5_available() {
  return false;
}

at::Tensor read_hdf5_array(const std::string& path, const std::string& /*name*/,
                           at::ScalarType /*type*/) {
  throw std::runtime_error(path + ": this build reads no HDF5 files (built without libhdf5)");
}

}  // namespace omnipoint::data::formats
