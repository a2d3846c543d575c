#include "omnipoint/io/pickle.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace omnipoint::io {

// ---------------------------------------------------------------------------------------------
// PickleValue

PickleValue PickleValue::boolean(bool value) {
  PickleValue v;
  v.kind_ = Kind::kBool;
  v.bool_ = value;
  return v;
}
PickleValue PickleValue::integer(std::int64_t value) {
  PickleValue v;
  v.kind_ = Kind::kInt;
  v.int_ = value;
  return v;
}
PickleValue PickleValue::number(double value) {
  PickleValue v;
  v.kind_ = Kind::kFloat;
  v.float_ = value;
  return v;
}
PickleValue PickleValue::string(std::string value) {
  PickleValue v;
  v.kind_ = Kind::kString;
  v.string_ = std::move(value);
  return v;
}
PickleValue PickleValue::sequence(Kind kind, std::vector<PickleValue> items) {
  if (kind != Kind::kList && kind != Kind::kTuple)
    throw std::logic_error("PickleValue::sequence: not a list or tuple kind");
  PickleValue v;
  v.kind_ = kind;
  v.items_ = std::move(items);
  return v;
}
PickleValue PickleValue::dict(std::vector<PickleValue> keys, std::vector<PickleValue> values) {
  if (keys.size() != values.size()) throw std::logic_error("PickleValue::dict: sizes differ");
  PickleValue v;
  v.kind_ = Kind::kDict;
  v.items_ = std::move(keys);
  v.values_ = std::move(values);
  return v;
}
PickleValue PickleValue::tensor(at::Tensor value) {
  PickleValue v;
  v.kind_ = Kind::kTensor;
  v.tensor_ = std::move(value);
  return v;
}

const char* PickleValue::kind_name() const {
  switch (kind_) {
    case Kind::kNone:
      return "None";
    case Kind::kBool:
      return "bool";
    case Kind::kInt:
      return "int";
    case Kind::kFloat:
      return "float";
    case Kind::kString:
      return "str";
    case Kind::kList:
      return "list";
    case Kind::kTuple:
      return "tuple";
    case Kind::kDict:
      return "dict";
    case Kind::kTensor:
      break;
  }
  return "tensor";
}

void PickleValue::expect(Kind kind) const {
  if (kind_ != kind) throw std::logic_error(std::string("PickleValue: a ") + kind_name());
}
bool PickleValue::as_bool() const {
  expect(Kind::kBool);
  return bool_;
}
std::int64_t PickleValue::as_int() const {
  expect(Kind::kInt);
  return int_;
}
double PickleValue::as_float() const {
  if (kind_ == Kind::kInt) return static_cast<double>(int_);
  expect(Kind::kFloat);
  return float_;
}
const std::string& PickleValue::as_string() const {
  expect(Kind::kString);
  return string_;
}
const std::vector<PickleValue>& PickleValue::items() const {
  if (kind_ != Kind::kTuple) expect(Kind::kList);
  return items_;
}
const std::vector<PickleValue>& PickleValue::keys() const {
  expect(Kind::kDict);
  return items_;
}
const std::vector<PickleValue>& PickleValue::values() const {
  expect(Kind::kDict);
  return values_;
}
const at::Tensor& PickleValue::as_tensor() const {
  expect(Kind::kTensor);
  return tensor_;
}
const PickleValue* PickleValue::find(const std::string& key) const {
  expect(Kind::kDict);
  for (std::size_t i = 0; i < items_.size(); ++i)
    if (items_[i].kind_ == Kind::kString && items_[i].string_ == key) return &values_[i];
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// The unpickler

namespace {

// What the unpickler's stack holds: values by index into its arenas (so a list that is
// appended to after being stored elsewhere is one list, and nothing owns anything cyclically).
enum class ObjKind {
  kNone,
  kBool,
  kInt,
  kFloat,
  kString,
  kList,
  kTuple,
  kDict,
  kTensor,
  kGlobal,   // an allowed callable (Global)
  kStorage,  // a persistent storage (index into storages)
};
enum class Global { kOrderedDict, kRebuildTensor, kRebuildParameter, kStorageType };

struct Obj {
  ObjKind kind = ObjKind::kNone;
  std::int64_t value = 0;  // bool, int, arena index, Global
  double number = 0;
  at::ScalarType dtype = at::kFloat;  // a storage type's
};

struct DictData {
  std::vector<Obj> keys, values;
  std::unordered_map<std::string, std::size_t> index;  // canonical key -> position
};

// The storage types torch.save names (torch.<Name>), by dtype.
const std::pair<const char*, at::ScalarType> kStorageTypes[] = {
    {"FloatStorage", at::kFloat},   {"HalfStorage", at::kHalf}, {"BFloat16Storage", at::kBFloat16},
    {"DoubleStorage", at::kDouble}, {"LongStorage", at::kLong}, {"IntStorage", at::kInt},
    {"ShortStorage", at::kShort},   {"CharStorage", at::kChar}, {"ByteStorage", at::kByte},
    {"BoolStorage", at::kBool}};

// Text from the file, safe to print on one line.
std::string printable(const std::string& text) {
  std::string out;
  for (const char c : text.substr(0, 120)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  return text.size() > 120 ? out + "..." : out;
}

class Unpickler {
 public:
  Unpickler(const char* data, std::size_t size, const StorageLoader& load,
            const std::string& source)
      : data_(reinterpret_cast<const unsigned char*>(data)),
        size_(size),
        load_(load),
        source_(source) {}

  PickleValue run() {
    while (true) {
      if (at_ >= size_) fail("ends without a STOP opcode (truncated?)");
      const std::size_t opcode_at = at_;
      const unsigned char op = data_[at_++];
      switch (op) {
        case 0x80: {  // PROTO
          const unsigned version = byte();
          if (version < 2 || version > 5)
            fail("pickle protocol " + std::to_string(version) + " (expected 2 to 5)");
          break;
        }
        case 0x95:  // FRAME: a length hint
          take(8);
          break;
        case '.': {  // STOP
          const Obj result = pop();
          std::size_t budget = 16 * size_ + 1024;
          return convert(result, 0, budget);
        }
        case '(':
          marks_.push_back(stack_.size());
          break;
        case '0':  // POP: the top, or the mark when the frame is empty
          if (stack_.size() > base())
            stack_.pop_back();
          else if (!marks_.empty())
            marks_.pop_back();
          else
            fail("POP on an empty stack");
          break;
        case '1':  // POP_MARK
          pop_mark();
          break;
        case '2':  // DUP
          push(top());
          break;
        case 'N':
          push({});
          break;
        case 0x88:
        case 0x89:
          push(make(ObjKind::kBool, op == 0x88));
          break;
        case 'J':
          push(make(ObjKind::kInt, static_cast<std::int32_t>(little(4))));
          break;
        case 'K':
          push(make(ObjKind::kInt, static_cast<std::int64_t>(little(1))));
          break;
        case 'M':
          push(make(ObjKind::kInt, static_cast<std::int64_t>(little(2))));
          break;
        case 0x8a:  // LONG1
          push(make(ObjKind::kInt, long_integer(byte())));
          break;
        case 0x8b: {  // LONG4
          const std::uint64_t length = little(4);
          if (length > 8) fail("an integer wider than 64 bits");
          push(make(ObjKind::kInt, long_integer(static_cast<std::size_t>(length))));
          break;
        }
        case 'G': {  // BINFLOAT, big-endian
          std::uint64_t bits = 0;
          for (const unsigned char c : take(8)) bits = bits << 8 | c;
          Obj obj{ObjKind::kFloat};
          std::memcpy(&obj.number, &bits, sizeof(double));
          push(obj);
          break;
        }
        case 'X':  // BINUNICODE
        case 'T':  // BINSTRING (Python 2 str)
          push(string(static_cast<std::size_t>(little(4))));
          break;
        case 0x8c:  // SHORT_BINUNICODE
        case 'U':   // SHORT_BINSTRING
          push(string(byte()));
          break;
        case 0x8d:  // BINUNICODE8
          push(string(checked_length(little(8))));
          break;
        case '}':
          push(new_dict());
          break;
        case ']':
          push(new_sequence(ObjKind::kList, {}));
          break;
        case ')':
          push(new_sequence(ObjKind::kTuple, {}));
          break;
        case 't':
          push(new_sequence(ObjKind::kTuple, pop_mark()));
          break;
        case 0x85:
        case 0x86:
        case 0x87: {  // TUPLE1..3
          std::vector<Obj> items(static_cast<std::size_t>(op - 0x84));
          for (std::size_t i = items.size(); i-- > 0;) items[i] = pop();
          push(new_sequence(ObjKind::kTuple, std::move(items)));
          break;
        }
        case 'l':
          push(new_sequence(ObjKind::kList, pop_mark()));
          break;
        case 'd': {
          const std::vector<Obj> items = pop_mark();
          const Obj dict = new_dict();
          set_items(dict, items);
          push(dict);
          break;
        }
        case 'a': {  // APPEND
          const Obj item = pop();
          list_of(top()).push_back(item);
          break;
        }
        case 'e': {  // APPENDS
          std::vector<Obj> items = pop_mark();
          std::vector<Obj>& list = list_of(top());
          list.insert(list.end(), items.begin(), items.end());
          break;
        }
        case 's': {  // SETITEM
          const Obj value = pop(), key = pop();
          set_items(top(), {key, value});
          break;
        }
        case 'u': {  // SETITEMS
          const std::vector<Obj> items = pop_mark();
          set_items(top(), items);
          break;
        }
        case 'c': {  // GLOBAL "module\nname\n"
          const std::string module = line(), name = line();
          push(global(module, name));
          break;
        }
        case 0x93: {  // STACK_GLOBAL
          const Obj name = pop(), module = pop();
          if (name.kind != ObjKind::kString || module.kind != ObjKind::kString)
            fail("STACK_GLOBAL without two strings");
          push(global(strings_[index(module)], strings_[index(name)]));
          break;
        }
        case 'R': {  // REDUCE
          const Obj args = pop(), callable = pop();
          push(reduce(callable, args));
          break;
        }
        case 'b': {  // BUILD: an OrderedDict's attributes (a state dict's _metadata)
          const Obj state = pop();
          if (top().kind != ObjKind::kDict ||
              (state.kind != ObjKind::kDict && state.kind != ObjKind::kNone))
            fail("BUILD is allowed only for a dict's attributes");
          break;
        }
        case 'Q':  // BINPERSID
          push(persistent(pop()));
          break;
        case 'q':
          memo_[static_cast<std::uint32_t>(little(1))] = top();
          break;
        case 'r':
          memo_[static_cast<std::uint32_t>(little(4))] = top();
          break;
        case 0x94:
          memo_[static_cast<std::uint32_t>(memo_.size())] = top();
          break;
        case 'h':
          push(memo(little(1)));
          break;
        case 'j':
          push(memo(little(4)));
          break;
        default:
          fail("unsupported pickle opcode 0x" + hex(op) + " at byte " + std::to_string(opcode_at));
      }
    }
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    throw std::runtime_error(source_ + ": " + problem);
  }
  static std::string hex(unsigned value) {
    const char* digits = "0123456789abcdef";
    return std::string{digits[(value >> 4) & 15], digits[value & 15]};
  }

  // ---- bytes
  std::vector<unsigned char> take(std::size_t n) {
    if (n > size_ - at_) fail("ends inside an opcode's argument (truncated?)");
    std::vector<unsigned char> out(data_ + at_, data_ + at_ + n);
    at_ += n;
    return out;
  }
  unsigned byte() { return take(1)[0]; }
  std::uint64_t little(int bytes) {
    std::uint64_t value = 0;
    const std::vector<unsigned char> raw = take(static_cast<std::size_t>(bytes));
    for (int i = bytes - 1; i >= 0; --i) value = value << 8 | raw[static_cast<std::size_t>(i)];
    return value;
  }
  std::size_t checked_length(std::uint64_t length) const {
    if (length > size_ - at_) fail("a string runs past the end (truncated?)");
    return static_cast<std::size_t>(length);
  }
  // A little-endian two's-complement integer of `length` bytes (at most 8).
  std::int64_t long_integer(std::size_t length) {
    if (length > 8) fail("an integer wider than 64 bits");
    if (length == 0) return 0;
    const std::vector<unsigned char> raw = take(length);
    std::uint64_t value = 0;
    for (std::size_t i = length; i-- > 0;) value = value << 8 | raw[i];
    if (length < 8 && (raw[length - 1] & 0x80)) value |= ~std::uint64_t{0} << (8 * length);
    return static_cast<std::int64_t>(value);
  }
  // A text line of GLOBAL, without its newline.
  std::string line() {
    const std::size_t limit = std::min(size_, at_ + 256);
    for (std::size_t end = at_; end < limit; ++end) {
      if (data_[end] == '\n') {
        std::string text(reinterpret_cast<const char*>(data_ + at_), end - at_);
        at_ = end + 1;
        return text;
      }
    }
    fail("a GLOBAL name without its newline");
  }
  Obj string(std::size_t length) {
    checked_length(length);
    strings_.emplace_back(reinterpret_cast<const char*>(data_ + at_), length);
    at_ += length;
    return make(ObjKind::kString, static_cast<std::int64_t>(strings_.size() - 1));
  }

  // ---- stack
  static Obj make(ObjKind kind, std::int64_t value) {
    Obj obj{kind};
    obj.value = value;
    return obj;
  }
  std::size_t base() const { return marks_.empty() ? 0 : marks_.back(); }
  void push(const Obj& obj) { stack_.push_back(obj); }
  Obj pop() {
    if (stack_.size() <= base()) fail("pops from an empty stack (malformed pickle)");
    const Obj obj = stack_.back();
    stack_.pop_back();
    return obj;
  }
  const Obj& top() const {
    if (stack_.size() <= base()) fail("reads an empty stack (malformed pickle)");
    return stack_.back();
  }
  std::vector<Obj> pop_mark() {
    if (marks_.empty()) fail("no MARK to pop to (malformed pickle)");
    const std::size_t mark = marks_.back();
    marks_.pop_back();
    std::vector<Obj> items(stack_.begin() + static_cast<std::ptrdiff_t>(mark), stack_.end());
    stack_.resize(mark);
    return items;
  }
  Obj memo(std::uint64_t key) const {
    const auto found = memo_.find(static_cast<std::uint32_t>(key));
    if (found == memo_.end()) fail("reads memo entry " + std::to_string(key) + ", never stored");
    return found->second;
  }
  static std::size_t index(const Obj& obj) { return static_cast<std::size_t>(obj.value); }

  // ---- containers
  Obj new_sequence(ObjKind kind, std::vector<Obj> items) {
    sequences_.push_back(std::move(items));
    return make(kind, static_cast<std::int64_t>(sequences_.size() - 1));
  }
  Obj new_dict() {
    dicts_.emplace_back();
    return make(ObjKind::kDict, static_cast<std::int64_t>(dicts_.size() - 1));
  }
  std::vector<Obj>& list_of(const Obj& obj) {
    if (obj.kind != ObjKind::kList) fail("APPEND to a " + name_of(obj) + ", not a list");
    return sequences_[index(obj)];
  }
  // Python's equality of hashable keys: True == 1 == 1.0.
  std::string canonical_key(const Obj& key) const {
    switch (key.kind) {
      case ObjKind::kNone:
        return "N";
      case ObjKind::kBool:
      case ObjKind::kInt:
        return "i" + std::to_string(key.value);
      case ObjKind::kFloat:
        if (std::nearbyint(key.number) == key.number && std::fabs(key.number) < 9e18)
          return "i" + std::to_string(static_cast<std::int64_t>(key.number));
        return "f" + std::to_string(key.number);
      case ObjKind::kString:
        return "s" + strings_[index(key)];
      default:
        fail("a dict key of type " + name_of(key) + " (checkpoints key by str or int)");
    }
  }
  void set_items(const Obj& target, const std::vector<Obj>& items) {
    if (target.kind != ObjKind::kDict) fail("SETITEM on a " + name_of(target) + ", not a dict");
    if (items.size() % 2 != 0) fail("SETITEMS with an odd number of items");
    DictData& dict = dicts_[index(target)];
    for (std::size_t i = 0; i < items.size(); i += 2) {
      const auto [slot, inserted] = dict.index.emplace(canonical_key(items[i]), dict.keys.size());
      if (inserted) {
        dict.keys.push_back(items[i]);
        dict.values.push_back(items[i + 1]);
      } else {
        dict.values[slot->second] = items[i + 1];
      }
    }
  }

  // ---- globals, calls, storages
  Obj global(const std::string& module, const std::string& name) const {
    Obj obj{ObjKind::kGlobal};
    if (module == "collections" && name == "OrderedDict") {
      obj.value = static_cast<std::int64_t>(Global::kOrderedDict);
    } else if (module == "torch._utils" && name == "_rebuild_tensor_v2") {
      obj.value = static_cast<std::int64_t>(Global::kRebuildTensor);
    } else if (module == "torch._utils" && name == "_rebuild_parameter") {
      obj.value = static_cast<std::int64_t>(Global::kRebuildParameter);
    } else if (module == "torch" && name.size() > 7 &&
               name.compare(name.size() - 7, 7, "Storage") == 0) {
      for (const auto& [storage, dtype] : kStorageTypes) {
        if (name == storage) {
          obj.value = static_cast<std::int64_t>(Global::kStorageType);
          obj.dtype = dtype;
          return obj;
        }
      }
      fail("tensor storage type torch." + printable(name) +
           " is not supported (float32, float16, bfloat16, float64, int64, int32, int16, int8, "
           "uint8 and bool are)");
    } else {
      fail("refuses the pickled global '" + printable(module) + "." + printable(name) +
           "': a checkpoint holds only tensors, dicts, lists, strings and numbers (Python's "
           "pickle would call it)");
    }
    return obj;
  }
  std::string name_of(const Obj& obj) const {
    static const char* names[] = {"None",  "bool", "int",    "float",  "str",    "list",
                                  "tuple", "dict", "tensor", "global", "storage"};
    return names[static_cast<int>(obj.kind)];
  }
  const std::vector<Obj>& tuple_items(const Obj& obj, const char* what) const {
    if (obj.kind != ObjKind::kTuple) fail(std::string(what) + " is not a tuple");
    return sequences_[index(obj)];
  }
  std::int64_t integer(const Obj& obj, const char* what) const {
    if (obj.kind != ObjKind::kInt)
      fail(std::string(what) + " is a " + name_of(obj) + ", not an int");
    return obj.value;
  }
  // Backward hooks (and torch 2's tensor metadata) must be empty: nothing to run.
  void require_empty(const Obj& obj, const char* what) const {
    if (obj.kind == ObjKind::kNone) return;
    if (obj.kind != ObjKind::kDict || !dicts_[index(obj)].keys.empty())
      fail(std::string("a tensor with ") + what + " (only plain tensors are read)");
  }

  Obj reduce(const Obj& callable, const Obj& args_obj) {
    if (callable.kind != ObjKind::kGlobal) fail("REDUCE calls a " + name_of(callable));
    const std::vector<Obj> args = tuple_items(args_obj, "REDUCE's arguments");
    switch (static_cast<Global>(callable.value)) {
      case Global::kOrderedDict:
        if (!args.empty()) fail("collections.OrderedDict called with arguments");
        return new_dict();
      case Global::kRebuildParameter:
        if (args.size() != 3 || args[0].kind != ObjKind::kTensor)
          fail("torch._utils._rebuild_parameter takes (tensor, requires_grad, hooks)");
        require_empty(args[2], "backward hooks");
        return args[0];
      case Global::kRebuildTensor:
        return rebuild_tensor(args);
      case Global::kStorageType:
        break;
    }
    fail("a storage type is not callable");
  }

  Obj persistent(const Obj& pid_obj) {
    const std::vector<Obj> pid = tuple_items(pid_obj, "a persistent id");
    if (pid.size() != 5 || pid[0].kind != ObjKind::kString || strings_[index(pid[0])] != "storage")
      fail("a persistent id other than ('storage', type, key, location, numel)");
    if (pid[1].kind != ObjKind::kGlobal ||
        static_cast<Global>(pid[1].value) != Global::kStorageType)
      fail("a storage whose type is not a torch storage type");
    std::string key;
    if (pid[2].kind == ObjKind::kString)
      key = strings_[index(pid[2])];
    else
      key = std::to_string(integer(pid[2], "a storage key"));
    if (pid[3].kind != ObjKind::kString) fail("a storage location that is not a string");
    const std::int64_t numel = integer(pid[4], "a storage's size");
    if (numel < 0) fail("a storage of negative size");
    const at::ScalarType dtype = pid[1].dtype;

    const auto cached = storage_keys_.find(key);
    if (cached != storage_keys_.end()) {
      const at::Tensor& storage = storages_[cached->second];
      if (storage.scalar_type() != dtype || storage.numel() < numel)
        fail("storage '" + printable(key) + "' is read with two dtypes or sizes");
      return make(ObjKind::kStorage, static_cast<std::int64_t>(cached->second));
    }
    at::Tensor storage = load_(StorageRequest{key, dtype, numel});
    if (!storage.defined() || storage.scalar_type() != dtype || storage.dim() != 1 ||
        storage.numel() < numel || !storage.is_contiguous())
      fail("storage '" + printable(key) + "' was not served as requested");
    storages_.push_back(storage.narrow(0, 0, numel));
    storage_keys_[key] = storages_.size() - 1;
    return make(ObjKind::kStorage, static_cast<std::int64_t>(storages_.size() - 1));
  }

  // torch._utils._rebuild_tensor_v2(storage, offset, size, stride, requires_grad, hooks[,
  // metadata]): a view of the storage, every element inside it.
  Obj rebuild_tensor(const std::vector<Obj>& args) {
    if ((args.size() != 6 && args.size() != 7) || args[0].kind != ObjKind::kStorage)
      fail(
          "torch._utils._rebuild_tensor_v2 takes (storage, offset, size, stride, requires_grad, "
          "hooks[, metadata])");
    const at::Tensor& storage = storages_[index(args[0])];
    const std::int64_t offset = integer(args[1], "a tensor's storage offset");
    const std::vector<Obj>& size_items = tuple_items(args[2], "a tensor's size");
    const std::vector<Obj>& stride_items = tuple_items(args[3], "a tensor's stride");
    if (size_items.size() != stride_items.size())
      fail("a tensor's size and stride differ in length");
    if (size_items.size() > 32) fail("a tensor of more than 32 dimensions");
    require_empty(args[5], "backward hooks");
    if (args.size() == 7) require_empty(args[6], "metadata");

    const std::int64_t available = storage.numel();
    if (offset < 0 || offset > available)
      fail("a tensor's storage offset lies outside its storage");
    std::vector<std::int64_t> sizes, strides;
    std::int64_t last = offset, count = 1;  // the highest element index, the element count
    bool empty = false;
    for (std::size_t d = 0; d < size_items.size(); ++d) {
      const std::int64_t n = integer(size_items[d], "a tensor's size");
      const std::int64_t s = integer(stride_items[d], "a tensor's stride");
      if (n < 0 || s < 0) fail("a tensor with a negative size or stride");
      sizes.push_back(n);
      strides.push_back(s);
      if (n == 0) empty = true;
    }
    if (!empty) {
      for (std::size_t d = 0; d < sizes.size(); ++d) {
        // last + (n - 1)·s < available, and count·n <= available, without overflow.
        const std::int64_t steps = sizes[d] - 1;
        if (strides[d] != 0 && steps > (available - 1 - last) / strides[d])
          fail("a tensor reaches past the end of its storage");
        last += steps * strides[d];
        if (sizes[d] > available / count)
          fail("a tensor of more elements than its storage (overlapping strides are not read)");
        count *= sizes[d];
      }
      if (last >= available) fail("a tensor reaches past the end of its storage");
    }
    tensors_.push_back(storage.as_strided(sizes, strides, storage.storage_offset() + offset));
    return make(ObjKind::kTensor, static_cast<std::int64_t>(tensors_.size() - 1));
  }

  // ---- the result, as an owned tree (depth and size bounded: no cycles, no blow-up)
  PickleValue convert(const Obj& obj, int depth, std::size_t& budget) const {
    if (depth > kMaxPickleDepth)
      fail("values nest deeper than " + std::to_string(kMaxPickleDepth) + " levels (or a cycle)");
    if (budget-- == 0) fail("shared values expand beyond any checkpoint's size");
    switch (obj.kind) {
      case ObjKind::kNone:
        return {};
      case ObjKind::kBool:
        return PickleValue::boolean(obj.value != 0);
      case ObjKind::kInt:
        return PickleValue::integer(obj.value);
      case ObjKind::kFloat:
        return PickleValue::number(obj.number);
      case ObjKind::kString:
        return PickleValue::string(strings_[index(obj)]);
      case ObjKind::kList:
      case ObjKind::kTuple: {
        std::vector<PickleValue> items;
        for (const Obj& item : sequences_[index(obj)])
          items.push_back(convert(item, depth + 1, budget));
        return PickleValue::sequence(
            obj.kind == ObjKind::kList ? PickleValue::Kind::kList : PickleValue::Kind::kTuple,
            std::move(items));
      }
      case ObjKind::kDict: {
        const DictData& dict = dicts_[index(obj)];
        std::vector<PickleValue> keys, values;
        for (std::size_t i = 0; i < dict.keys.size(); ++i) {
          keys.push_back(convert(dict.keys[i], depth + 1, budget));
          values.push_back(convert(dict.values[i], depth + 1, budget));
        }
        return PickleValue::dict(std::move(keys), std::move(values));
      }
      case ObjKind::kTensor:
        return PickleValue::tensor(tensors_[index(obj)]);
      case ObjKind::kGlobal:
      case ObjKind::kStorage:
        break;
    }
    fail("a " + name_of(obj) + " stands where a value belongs");
  }

  const unsigned char* data_;
  std::size_t size_, at_ = 0;
  const StorageLoader& load_;
  const std::string& source_;

  std::vector<Obj> stack_;
  std::vector<std::size_t> marks_;
  std::unordered_map<std::uint32_t, Obj> memo_;
  std::vector<std::string> strings_;
  std::vector<std::vector<Obj>> sequences_;
  std::vector<DictData> dicts_;
  std::vector<at::Tensor> storages_, tensors_;
  std::unordered_map<std::string, std::size_t> storage_keys_;
};

}  // namespace

PickleValue unpickle(const char* data, std::size_t size, const StorageLoader& load_storage,
                     const std::string& source) {
  return Unpickler(data, size, load_storage, source).run();
}

}  // namespace omnipoint::io
