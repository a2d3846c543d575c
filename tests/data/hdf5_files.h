#pragma once
// HDF5 files as h5py writes Hypersim's: one array named "dataset", float16 or int16, chunked
// and gzip-compressed (libhdf5's C API; only where the build has it).
#ifdef OMNIPOINT_WITH_HDF5
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <filesystem>
#include <string>
#include <vector>

namespace omnipoint::test {

// A float16 type as h5py makes numpy's (IEEE half, little-endian).
inline hid_t float16_type() {
  const hid_t type = H5Tcopy(H5T_IEEE_F32LE);
  H5Tset_fields(type, 15, 10, 5, 0, 10);
  H5Tset_size(type, 2);
  H5Tset_ebias(type, 15);
  return type;
}

// `values` (float32 or int32) as the array `name` of a new HDF5 file, stored as `file_type`,
// chunked and gzip-compressed at level 9 as the dataset's files are.
inline void write_hdf5(const std::filesystem::path& path, const at::Tensor& values, hid_t file_type,
                       const std::string& name = "dataset") {
  std::filesystem::create_directories(path.parent_path());
  const at::Tensor data = values.contiguous();
  std::vector<hsize_t> dims(data.sizes().begin(), data.sizes().end());
  const hid_t file = H5Fcreate(path.string().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(properties, static_cast<int>(dims.size()), dims.data());
  H5Pset_deflate(properties, 9);
  const hid_t dataset =
      H5Dcreate2(file, name.c_str(), file_type, space, H5P_DEFAULT, properties, H5P_DEFAULT);
  const hid_t memory = data.scalar_type() == at::kFloat ? H5T_NATIVE_FLOAT : H5T_NATIVE_INT32;
  ASSERT_GE(H5Dwrite(dataset, memory, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data_ptr()), 0) << path;
  H5Dclose(dataset);
  H5Pclose(properties);
  H5Sclose(space);
  H5Fclose(file);
}

inline void write_float16(const std::filesystem::path& path, const at::Tensor& values) {
  const hid_t type = float16_type();
  write_hdf5(path, values.to(at::kFloat), type);
  H5Tclose(type);
}

inline void write_int16(const std::filesystem::path& path, const at::Tensor& values) {
  write_hdf5(path, values.to(at::kInt), H5T_STD_I16LE);
}

}  // namespace omnipoint::test

#endif  // OMNIPOINT_WITH_HDF5
