#pragma once
// A restricted unpickler for what PyTorch checkpoints hold, and nothing else.
//
// Python's pickle runs whatever callable a file names; this reader knows a fixed set of values
// and refuses every other global with one line naming it, so a checkpoint cannot run code:
//   values:   None, bool, int (up to 64 bits), float, str, list, tuple, dict and
//             collections.OrderedDict (keys None, bool, int, float or str);
//   tensors:  torch._utils._rebuild_tensor_v2 (and _rebuild_parameter around it) over a
//             persistent ('storage', torch.<Dtype>Storage, key, location, numel) of float32,
//             float16, bfloat16, float64, int64, int32, int16, int8, uint8 or bool, with its
//             storage offset, sizes and strides (checked against the storage).
// Protocols 2 to 5, binary opcodes only (torch.save writes protocol 2). The persistent
// storages come from the caller (io/torch_checkpoint.h reads them from the zip's data/ folder).
// Values nest at most kMaxPickleDepth levels (no cycles), and shared sub-objects may not blow
// the tree up beyond a bound proportional to the input. Every problem is one
// std::runtime_error naming `source`.
#include <ATen/core/Tensor.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace omnipoint::io {

constexpr int kMaxPickleDepth = 64;

class PickleValue {
 public:
  enum class Kind { kNone, kBool, kInt, kFloat, kString, kList, kTuple, kDict, kTensor };

  PickleValue() = default;  // None
  static PickleValue boolean(bool value);
  static PickleValue integer(std::int64_t value);
  static PickleValue number(double value);
  static PickleValue string(std::string value);
  static PickleValue sequence(Kind kind, std::vector<PickleValue> items);  // kList or kTuple
  static PickleValue dict(std::vector<PickleValue> keys, std::vector<PickleValue> values);
  static PickleValue tensor(at::Tensor value);

  Kind kind() const { return kind_; }
  bool is(Kind kind) const { return kind_ == kind; }
  // Python's name of the kind ("dict", "tensor", ...), for messages.
  const char* kind_name() const;

  // The accessors assume the kind (std::logic_error otherwise).
  bool as_bool() const;
  std::int64_t as_int() const;
  double as_float() const;  // a float, or an int converted
  const std::string& as_string() const;
  const std::vector<PickleValue>& items() const;  // list or tuple
  const std::vector<PickleValue>& keys() const;   // dict, in insertion order
  const std::vector<PickleValue>& values() const;
  const at::Tensor& as_tensor() const;
  // A dict's value under a string key, or nullptr.
  const PickleValue* find(const std::string& key) const;

 private:
  void expect(Kind kind) const;

  Kind kind_ = Kind::kNone;
  bool bool_ = false;
  std::int64_t int_ = 0;
  double float_ = 0;
  std::string string_;
  std::vector<PickleValue> items_;   // list, tuple; a dict's keys
  std::vector<PickleValue> values_;  // a dict's values
  at::Tensor tensor_;
};

// A persistent storage the pickle asks for: `numel` elements of `dtype` under `key`.
struct StorageRequest {
  std::string key;
  at::ScalarType dtype = at::kFloat;
  std::int64_t numel = 0;
};
// Returns the storage as a 1-D tensor of at least `numel` elements of the dtype, or throws
// std::runtime_error. Called once per key: the unpickler shares one storage among its tensors.
using StorageLoader = std::function<at::Tensor(const StorageRequest&)>;

// Unpickles `data`. Tensors are views of the loaded storages (they share memory with them).
PickleValue unpickle(const char* data, std::size_t size, const StorageLoader& load_storage,
                     const std::string& source);

}  // namespace omnipoint::io
