#include "omnipoint/io/safetensors.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/mapped_file.h"

// Tensor bytes are copied as they lie in memory; safetensors data is little-endian.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "safetensors I/O assumes a little-endian host");

namespace omnipoint::io {
namespace {

using nlohmann::json;

constexpr std::uint64_t kMaxHeaderSize = 100u
                                         << 20;  // the reference implementation's cap is 100 MB
constexpr char kMetadataKey[] = "__metadata__";

struct DtypeInfo {
  const char* name;
  at::ScalarType type;
};
// In increasing alignment, the order of the reference implementation's Dtype enum; the
// writer lays data out from the last entry to the first, so every tensor starts aligned.
constexpr DtypeInfo kDtypes[] = {
    {"BOOL", at::kBool},  {"U8", at::kByte},       {"I8", at::kChar}, {"I16", at::kShort},
    {"F16", at::kHalf},   {"BF16", at::kBFloat16}, {"I32", at::kInt}, {"F32", at::kFloat},
    {"F64", at::kDouble}, {"I64", at::kLong},
};
constexpr char kSupportedDtypes[] = "F64, F32, F16, BF16, I64, I32, I16, I8, U8, BOOL";

const DtypeInfo* find_dtype(const std::string& name) {
  for (const auto& d : kDtypes) {
    if (name == d.name) return &d;
  }
  return nullptr;
}

int alignment_rank(at::ScalarType type) {
  for (int i = 0; i < static_cast<int>(std::size(kDtypes)); ++i) {
    if (kDtypes[i].type == type) return i;
  }
  return -1;
}

bool is_stored_float(at::ScalarType type) {
  return type == at::kDouble || type == at::kFloat || type == at::kHalf || type == at::kBFloat16;
}

[[noreturn]] void fail(const std::string& name, const std::string& what) {
  throw std::runtime_error(name + ": invalid safetensors file: " + what);
}

std::string shape_string(const std::vector<std::int64_t>& shape) {
  std::ostringstream out;
  out << '[';
  for (std::size_t i = 0; i < shape.size(); ++i) out << (i ? ", " : "") << shape[i];
  out << ']';
  return out.str();
}

// One header entry, validated on its own (the data layout is checked across entries).
struct Entry {
  std::string key;
  const DtypeInfo* dtype = nullptr;
  std::vector<std::int64_t> shape;
  std::uint64_t begin = 0, end = 0;
};

std::uint64_t non_negative_integer(const json& value, bool& ok) {
  ok = value.is_number_unsigned() || (value.is_number_integer() && value.get<std::int64_t>() >= 0);
  return ok ? value.get<std::uint64_t>() : 0;
}

Entry parse_entry(const std::string& key, const json& value, const std::string& name) {
  const std::string where = "tensor '" + key + "': ";
  if (!value.is_object()) fail(name, where + "entry is not a JSON object");
  for (const auto& field : value.items()) {
    if (field.key() != "dtype" && field.key() != "shape" && field.key() != "data_offsets") {
      fail(name, where + "unexpected field '" + field.key() + "'");
    }
  }
  Entry entry;
  entry.key = key;

  const auto dtype = value.find("dtype");
  if (dtype == value.end() || !dtype->is_string())
    fail(name, where + "missing string field 'dtype'");
  entry.dtype = find_dtype(dtype->get<std::string>());
  if (entry.dtype == nullptr) {
    fail(name, where + "unsupported dtype '" + dtype->get<std::string>() +
                   "' (supported: " + kSupportedDtypes + ")");
  }

  const auto shape = value.find("shape");
  if (shape == value.end() || !shape->is_array()) fail(name, where + "missing array field 'shape'");
  for (const json& dim : *shape) {
    bool ok = false;
    const std::uint64_t d = non_negative_integer(dim, ok);
    if (!ok || d > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
      fail(name, where + "'shape' must hold non-negative integers");
    }
    entry.shape.push_back(static_cast<std::int64_t>(d));
  }

  const auto offsets = value.find("data_offsets");
  if (offsets == value.end() || !offsets->is_array() || offsets->size() != 2) {
    fail(name, where + "missing field 'data_offsets' of two integers [begin, end]");
  }
  bool ok_begin = false, ok_end = false;
  entry.begin = non_negative_integer((*offsets)[0], ok_begin);
  entry.end = non_negative_integer((*offsets)[1], ok_end);
  if (!ok_begin || !ok_end) fail(name, where + "'data_offsets' must be two non-negative integers");
  if (entry.end < entry.begin) {
    fail(name, where + "'data_offsets' [" + std::to_string(entry.begin) + ", " +
                   std::to_string(entry.end) + "] end before they begin");
  }

  std::uint64_t bytes = c10::elementSize(entry.dtype->type);
  for (std::int64_t d : entry.shape) {
    if (__builtin_mul_overflow(bytes, static_cast<std::uint64_t>(d), &bytes)) {
      fail(name, where + "shape " + shape_string(entry.shape) + " is too large");
    }
  }
  if (entry.end - entry.begin != bytes) {
    fail(name, where + "'data_offsets' [" + std::to_string(entry.begin) + ", " +
                   std::to_string(entry.end) + "] span " + std::to_string(entry.end - entry.begin) +
                   " bytes but dtype " + entry.dtype->name + " and shape " +
                   shape_string(entry.shape) + " need " + std::to_string(bytes));
  }
  return entry;
}

// The tensors must tile the data section: sorted by offset, each starts where the previous
// one ended, and the last ends at the end of the file.
void check_layout(std::vector<Entry>& entries, std::uint64_t data_size, const std::string& name) {
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.begin != b.begin ? a.begin < b.begin : a.end < b.end;
  });
  std::uint64_t position = 0;
  const Entry* previous = nullptr;
  for (const Entry& entry : entries) {
    if (entry.end > data_size) {
      fail(name, "tensor '" + entry.key + "': 'data_offsets' end at " + std::to_string(entry.end) +
                     ", past the end of the data section (" + std::to_string(data_size) +
                     " bytes)");
    }
    if (entry.begin < position) {
      fail(name,
           "tensors '" + previous->key + "' and '" + entry.key + "' overlap in the data section");
    }
    if (entry.begin > position) {
      fail(name, "bytes [" + std::to_string(position) + ", " + std::to_string(entry.begin) +
                     ") of the data section belong to no tensor");
    }
    position = entry.end;
    previous = &entry;
  }
  if (position != data_size) {
    fail(name, "the last " + std::to_string(data_size - position) +
                   " bytes of the data section belong to no tensor");
  }
}

// nlohmann's messages start with "[json.exception.parse_error.101] "; keep the readable part.
std::string json_error_text(const std::exception& e) {
  std::string text = e.what();
  const std::size_t close = text.find("] ");
  return close == std::string::npos ? text : text.substr(close + 2);
}

std::string json_string(const std::string& text, const std::string& what) {
  try {
    return json(text).dump();
  } catch (const json::type_error&) {
    throw std::invalid_argument("cannot write safetensors: " + what + " is not valid UTF-8");
  }
}

// The header and the tensors in file order, shared by encode (to memory) and write (streamed).
struct Prepared {
  std::string header;  // padded JSON, without the length prefix
  std::vector<at::Tensor> tensors;
  std::uint64_t data_size = 0;
};

Prepared prepare(const std::map<std::string, at::Tensor>& tensors,
                 const std::map<std::string, std::string>& metadata,
                 std::optional<at::ScalarType> store_as) {
  if (store_as && !is_stored_float(*store_as)) {
    throw std::invalid_argument(std::string("cannot store floating-point tensors as ") +
                                c10::toString(*store_as) + " (expected F64, F32, F16 or BF16)");
  }
  struct Item {
    const std::string* name;
    at::Tensor tensor;
    int rank;
  };
  std::vector<Item> items;
  for (const auto& [name, tensor] : tensors) {
    if (!tensor.defined()) {
      throw std::invalid_argument("cannot write safetensors: tensor '" + name + "' is undefined");
    }
    at::Tensor t = tensor.detach();
    if (store_as && is_stored_float(t.scalar_type())) t = t.to(*store_as);
    t = t.to(at::kCPU).contiguous();
    const int rank = alignment_rank(t.scalar_type());
    if (rank < 0) {
      throw std::invalid_argument("cannot write safetensors: tensor '" + name + "' has dtype " +
                                  c10::toString(t.scalar_type()) +
                                  " (supported: " + kSupportedDtypes + ")");
    }
    items.push_back({&name, std::move(t), rank});
  }
  std::stable_sort(items.begin(), items.end(),
                   [](const Item& a, const Item& b) { return a.rank > b.rank; });

  Prepared out;
  std::string& h = out.header;
  h = "{";
  if (!metadata.empty()) {
    h += std::string("\"") + kMetadataKey + "\":{";
    bool first = true;
    for (const auto& [key, value] : metadata) {
      if (!first) h += ',';
      first = false;
      h += json_string(key, "metadata key '" + key + "'") + ':' +
           json_string(value, "the value of metadata key '" + key + "'");
    }
    h += '}';
  }
  for (const Item& item : items) {
    if (h.size() > 1) h += ',';
    const std::uint64_t bytes = item.tensor.numel() * item.tensor.element_size();
    h += json_string(*item.name, "tensor name '" + *item.name + "'");
    h += ":{\"dtype\":\"";
    h += kDtypes[item.rank].name;
    h += "\",\"shape\":[";
    for (int64_t i = 0; i < item.tensor.dim(); ++i) {
      h += (i ? "," : "") + std::to_string(item.tensor.size(i));
    }
    h += "],\"data_offsets\":[" + std::to_string(out.data_size) + "," +
         std::to_string(out.data_size + bytes) + "]}";
    out.data_size += bytes;
    out.tensors.push_back(item.tensor);
  }
  h += '}';
  h.append((8 - h.size() % 8) % 8, ' ');  // data starts 8-byte aligned
  return out;
}

std::string length_prefix(std::uint64_t n) {
  std::string out(8, '\0');
  for (int i = 0; i < 8; ++i) out[i] = static_cast<char>((n >> (8 * i)) & 0xff);
  return out;
}

}  // namespace

SafetensorsFile parse_safetensors(const char* data, std::size_t size, const std::string& name,
                                  const std::shared_ptr<const void>& keep_alive) {
  if (size < 8) fail(name, "shorter than the 8-byte header length");
  std::uint64_t header_size = 0;
  for (int i = 7; i >= 0; --i)
    header_size = (header_size << 8) | static_cast<unsigned char>(data[i]);
  if (header_size > kMaxHeaderSize) {
    fail(name, "header length " + std::to_string(header_size) + " exceeds the 100 MiB cap");
  }
  if (header_size > size - 8) {
    fail(name, "header length " + std::to_string(header_size) + " runs past the end of the file (" +
                   std::to_string(size) + " bytes)");
  }
  const char* header = data + 8;
  const char* payload = header + header_size;
  const std::uint64_t payload_size = size - 8 - header_size;

  // nlohmann keeps the last of duplicate keys silently; readers that kept the first would
  // see another file, so a parser callback rejects them in every object.
  std::vector<std::set<std::string>> open_objects;
  std::string duplicate;
  const json::parser_callback_t watch_keys = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) {
      open_objects.emplace_back();
    } else if (event == json::parse_event_t::object_end) {
      open_objects.pop_back();
    } else if (event == json::parse_event_t::key && duplicate.empty() &&
               !open_objects.back().insert(parsed.get<std::string>()).second) {
      duplicate = parsed.get<std::string>();
    }
    return true;
  };
  json root;
  try {
    root = json::parse(header, payload, watch_keys);
  } catch (const json::exception& e) {
    fail(name, "header is not valid JSON: " + json_error_text(e));
  }
  if (!root.is_object()) fail(name, "header is not a JSON object");
  if (!duplicate.empty()) fail(name, "duplicate key '" + duplicate + "' in the header");

  SafetensorsFile out;
  std::vector<Entry> entries;
  for (const auto& item : root.items()) {
    if (item.key() == kMetadataKey) {
      if (!item.value().is_object()) fail(name, "'__metadata__' is not a JSON object");
      for (const auto& field : item.value().items()) {
        if (!field.value().is_string()) {
          fail(name, "'__metadata__' entry '" + field.key() + "' is not a string");
        }
        out.metadata[field.key()] = field.value().get<std::string>();
      }
      continue;
    }
    entries.push_back(parse_entry(item.key(), item.value(), name));
  }
  check_layout(entries, payload_size, name);

  for (const Entry& entry : entries) {
    const std::size_t bytes = entry.end - entry.begin;
    const char* begin = payload + entry.begin;
    const auto element = static_cast<std::uintptr_t>(c10::elementSize(entry.dtype->type));
    at::Tensor t;
    if (keep_alive && bytes > 0 && reinterpret_cast<std::uintptr_t>(begin) % element == 0) {
      t = at::from_blob(
          const_cast<char*>(begin), entry.shape, [keep_alive](void*) {},
          at::TensorOptions().dtype(entry.dtype->type));
    } else {
      t = at::empty(entry.shape, at::TensorOptions().dtype(entry.dtype->type));
      if (bytes > 0) std::memcpy(t.data_ptr(), begin, bytes);
    }
    if (entry.dtype->type == at::kBool) {
      // A bool in memory must be 0 or 1; other bytes would be undefined behaviour later.
      const auto* p = reinterpret_cast<const unsigned char*>(payload + entry.begin);
      if (std::any_of(p, p + bytes, [](unsigned char b) { return b > 1; })) {
        fail(name, "tensor '" + entry.key + "': BOOL data holds a byte other than 0 or 1");
      }
    }
    out.tensors.emplace(entry.key, std::move(t));
  }
  return out;
}

SafetensorsFile read_safetensors(const std::string& path,
                                 std::optional<at::ScalarType> convert_to) {
  if (convert_to && !is_stored_float(*convert_to)) {
    throw std::invalid_argument(std::string("read_safetensors: cannot convert to ") +
                                c10::toString(*convert_to) + " (expected a floating-point type)");
  }
  SafetensorsFile file;
  {
    const MappedFile mapped(path);
    file = parse_safetensors(mapped.data(), mapped.size(), path);
  }
  if (convert_to) {
    for (auto& [key, tensor] : file.tensors) {
      if (is_stored_float(tensor.scalar_type())) tensor = tensor.to(*convert_to);
    }
  }
  return file;
}

std::string encode_safetensors(const std::map<std::string, at::Tensor>& tensors,
                               const std::map<std::string, std::string>& metadata,
                               std::optional<at::ScalarType> store_as) {
  const Prepared prepared = prepare(tensors, metadata, store_as);
  std::string out = length_prefix(prepared.header.size());
  out.reserve(8 + prepared.header.size() + prepared.data_size);
  out += prepared.header;
  for (const at::Tensor& t : prepared.tensors) {
    if (t.numel() > 0)
      out.append(static_cast<const char*>(t.data_ptr()), t.numel() * t.element_size());
  }
  return out;
}

void write_safetensors(const std::string& path, const std::map<std::string, at::Tensor>& tensors,
                       const std::map<std::string, std::string>& metadata,
                       std::optional<at::ScalarType> store_as) {
  const Prepared prepared = prepare(tensors, metadata, store_as);
  write_file_atomically(path, [&](std::ostream& out) {
    out << length_prefix(prepared.header.size()) << prepared.header;
    for (const at::Tensor& t : prepared.tensors) {
      if (t.numel() == 0) continue;
      out.write(static_cast<const char*>(t.data_ptr()),
                static_cast<std::streamsize>(t.numel() * t.element_size()));
    }
  });
}

}  // namespace omnipoint::io
