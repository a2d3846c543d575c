#include "omnipoint/data/formats/hdf5_array.h"

#include <ATen/ATen.h>
#include <hdf5.h>

#include <filesystem>
#include <stdexcept>
#include <vector>

namespace omnipoint::data::formats {
namespace {

// HDF5 prints its error stack to stderr when a call fails; our errors say what went wrong, so
// the printing is off while we read (the setting is per thread in a thread-safe libhdf5).
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &function_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, function_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t function_ = nullptr;
  void* data_ = nullptr;
};

// An HDF5 identifier closed by `close` when it goes out of scope.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

}  // namespace

bool hdf5_available() {
  return true;
}

at::Tensor read_hdf5_array(const std::string& path, const std::string& name, at::ScalarType type) {
  const auto fail = [&](const std::string& why) { throw std::runtime_error(path + ": " + why); };
  if (type != at::kFloat && type != at::kInt)
    throw std::invalid_argument("read_hdf5_array: reads float32 or int32 only");
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    fail("cannot open the file (missing or unreadable)");
  const QuietErrors quiet;
  if (H5Fis_hdf5(path.c_str()) <= 0) fail("not an HDF5 file");
  const Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) fail("cannot open the HDF5 file");
  if (H5Lexists(file.get(), name.c_str(), H5P_DEFAULT) <= 0) fail("no dataset \"" + name + "\"");
  const Handle dataset(H5Dopen2(file.get(), name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dataset.valid()) fail("\"" + name + "\" is not a dataset");
  const Handle stored_type(H5Dget_type(dataset.get()), H5Tclose);
  const H5T_class_t kind = H5Tget_class(stored_type.get());
  if (kind != H5T_FLOAT && kind != H5T_INTEGER)
    fail("dataset \"" + name + "\" holds neither floats nor integers");
  const Handle space(H5Dget_space(dataset.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 1 || rank > 4)
    fail("dataset \"" + name + "\" has " + std::to_string(rank) + " dimensions (1 to 4 read)");
  hsize_t dims[4] = {};
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  std::vector<int64_t> shape;
  double count = 1;
  for (int i = 0; i < rank; ++i) {
    shape.push_back(static_cast<int64_t>(dims[i]));
    count *= static_cast<double>(dims[i]);
  }
  if (count > double(1 << 30)) fail("dataset \"" + name + "\" holds more than 2^30 values");
  at::Tensor values = at::empty(shape, at::TensorOptions().dtype(type));
  const hid_t memory_type = type == at::kFloat ? H5T_NATIVE_FLOAT : H5T_NATIVE_INT32;
  if (H5Dread(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data_ptr()) < 0)
    fail("cannot read dataset \"" + name + "\" (corrupt or truncated file?)");
  return values;
}

}  // namespace omnipoint::data::formats
