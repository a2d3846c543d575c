#pragma once
// One array of an HDF5 file, read with the HDF5 C library (Debian's libhdf5; a build without it
// reads none: OMNIPOINT_WITH_HDF5). Hypersim stores each image as the dataset "dataset" of its
// own file (float16 colours and distances, int16 entity ids, gzip-compressed); HDF5 converts
// the stored type to the one asked for.
#include <ATen/core/Tensor.h>

#include <string>

namespace omnipoint::data::formats {

// Whether this build reads HDF5 files.
bool hdf5_available();

// The array `name` of the HDF5 file `path`, its stored values converted to `type` (at::kFloat
// or at::kInt), shaped as stored (rank 1 to 4). A missing file, a file that is not HDF5, no
// such dataset, values that are neither floats nor integers, more than 2^30 values or a build
// without HDF5 -> std::runtime_error naming the file and the problem.
at::Tensor read_hdf5_array(const std::string& path, const std::string& name, at::ScalarType type);

}  // namespace omnipoint::data::formats
