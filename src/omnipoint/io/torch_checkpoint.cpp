#include "omnipoint/io/torch_checkpoint.h"

#include <ATen/ATen.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>

#include "omnipoint/io/mapped_file.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/io/zip_archive.h"

// Storage bytes are used as they lie in memory; torch.save writes little-endian.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "PyTorch checkpoint reading assumes a little-endian host");

namespace omnipoint::io {
namespace {

const std::string kPickle = "data.pkl";

bool ends_with(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// The folder every record lies in: that of the one PREFIX/data.pkl.
std::string record_prefix(const ZipArchive& zip, const std::string& source) {
  std::string prefix;
  int found = 0;
  bool torchscript = false;
  for (const auto& [name, entry] : zip.entries()) {
    const std::size_t slash = name.find('/');
    if (slash != std::string::npos && name.substr(slash + 1) == kPickle) {
      prefix = name.substr(0, slash + 1);
      ++found;
    }
    if (ends_with(name, "/constants.pkl") || name.find("/code/") != std::string::npos)
      torchscript = true;
  }
  if (found == 0 && torchscript)
    throw std::runtime_error(source +
                             ": a TorchScript archive (torch.jit.save), not a checkpoint of "
                             "weights: save the model's state_dict() with torch.save");
  if (found != 1)
    throw std::runtime_error(source + ": not a PyTorch checkpoint (" +
                             (found == 0 ? std::string("no data.pkl in the zip archive")
                                         : std::string("several data.pkl records")) +
                             ")");
  return prefix;
}

// A storage record as a 1-D tensor: a view of the buffer (kept alive) where possible, else a
// copy. Bool bytes are normalised to 0/1 (any other byte is no bool).
at::Tensor storage_tensor(const char* bytes, std::size_t size, const StorageRequest& request,
                          const std::shared_ptr<const void>& keep_alive,
                          const std::string& source) {
  const auto element = static_cast<std::size_t>(c10::elementSize(request.dtype));
  const auto numel = static_cast<std::uint64_t>(request.numel);
  if (numel > size / element)
    throw std::runtime_error(source + ": storage '" + request.key + "' holds " +
                             std::to_string(size) + " bytes, its tensors need " +
                             std::to_string(numel) + " elements of " +
                             c10::toString(request.dtype));
  const auto n = static_cast<std::int64_t>(numel);
  if (request.dtype == at::kBool) {
    at::Tensor raw = at::empty({n}, at::kByte);
    if (n > 0) std::memcpy(raw.data_ptr(), bytes, static_cast<std::size_t>(n));
    return raw.ne(0);
  }
  const bool aligned = reinterpret_cast<std::uintptr_t>(bytes) % element == 0;
  if (keep_alive && aligned && n > 0) {
    return at::from_blob(
        const_cast<char*>(bytes), {n}, [keep_alive](void*) {},
        at::TensorOptions().dtype(request.dtype));
  }
  at::Tensor copy = at::empty({n}, request.dtype);
  if (n > 0) std::memcpy(copy.data_ptr(), bytes, static_cast<std::size_t>(n) * element);
  return copy;
}

nlohmann::json to_json(const PickleValue& value, const std::string& where,
                       const std::string& source) {
  using Kind = PickleValue::Kind;
  switch (value.kind()) {
    case Kind::kNone:
      return nullptr;
    case Kind::kBool:
      return value.as_bool();
    case Kind::kInt:
      return value.as_int();
    case Kind::kFloat:
      if (!std::isfinite(value.as_float()))
        throw std::runtime_error(source + ": " + where + " is not a finite number");
      return value.as_float();
    case Kind::kString:
      return value.as_string();
    case Kind::kList:
    case Kind::kTuple: {
      nlohmann::json out = nlohmann::json::array();
      for (const PickleValue& item : value.items()) out.push_back(to_json(item, where, source));
      return out;
    }
    case Kind::kDict: {
      nlohmann::json out = nlohmann::json::object();
      for (std::size_t i = 0; i < value.keys().size(); ++i) {
        if (!value.keys()[i].is(Kind::kString))
          throw std::runtime_error(source + ": " + where + " has a " + value.keys()[i].kind_name() +
                                   " key (JSON keys are strings)");
        const std::string& key = value.keys()[i].as_string();
        out[key] = to_json(value.values()[i], where + "." + key, source);
      }
      return out;
    }
    case Kind::kTensor:
      break;
  }
  throw std::runtime_error(source + ": " + where + " holds a tensor");
}

// name -> tensor, or a runtime_error naming the first entry that is not.
std::map<std::string, at::Tensor> state_dict_of(const PickleValue& dict, const std::string& what,
                                                const std::string& source) {
  std::map<std::string, at::Tensor> out;
  for (std::size_t i = 0; i < dict.keys().size(); ++i) {
    const PickleValue& key = dict.keys()[i];
    const PickleValue& value = dict.values()[i];
    if (!key.is(PickleValue::Kind::kString))
      throw std::runtime_error(source + ": " + what + " has a " + key.kind_name() +
                               " key (state dicts are keyed by name)");
    if (!value.is(PickleValue::Kind::kTensor))
      throw std::runtime_error(source + ": " + what + " entry '" + key.as_string() + "' is a " +
                               value.kind_name() + ", not a tensor");
    out[key.as_string()] = value.as_tensor();
  }
  return out;
}

bool is_stored_float(at::ScalarType type) {
  return type == at::kDouble || type == at::kFloat || type == at::kHalf || type == at::kBFloat16;
}

}  // namespace

bool looks_like_legacy_torch(const char* data, std::size_t size) {
  // The legacy format begins with its magic number pickled: PROTO n, LONG1 of 10 bytes
  // 0x1950a86a20f9469cfc6c (little-endian).
  static const unsigned char kMagic[] = {0x8a, 0x0a, 0x6c, 0xfc, 0x9c, 0x46,
                                         0xf9, 0x20, 0x6a, 0xa8, 0x50, 0x19};
  return size >= 2 + sizeof kMagic && static_cast<unsigned char>(data[0]) == 0x80 &&
         std::memcmp(data + 2, kMagic, sizeof kMagic) == 0;
}

std::string legacy_torch_message(const std::string& source) {
  return source +
         ": a PyTorch checkpoint in the pre-1.6 format (a bare pickle stream), which is not "
         "read: re-save it with PyTorch >= 1.6, e.g. python3 -c \"import torch; "
         "torch.save(torch.load('OLD', map_location='cpu'), 'NEW.pt')\"";
}

PickleValue parse_torch_checkpoint(const char* data, std::size_t size, const std::string& source,
                                   std::shared_ptr<const void> keep_alive) {
  if (looks_like_legacy_torch(data, size)) throw std::runtime_error(legacy_torch_message(source));
  if (!looks_like_zip(data, size))
    throw std::runtime_error(source +
                             ": not a PyTorch checkpoint (torch.save writes a zip archive)");
  const ZipArchive zip(data, size, source);
  const std::string prefix = record_prefix(zip, source);
  if (zip.contains(prefix + "byteorder")) {
    std::size_t length = 0;
    const char* order = zip.data(prefix + "byteorder", &length);
    if (std::string(order, length) != "little")
      throw std::runtime_error(source + ": a checkpoint of byte order '" +
                               std::string(order, std::min<std::size_t>(length, 16)) +
                               "' (only little-endian ones are read)");
  }
  const StorageLoader load = [&](const StorageRequest& request) {
    const std::string record = prefix + "data/" + request.key;
    if (!zip.contains(record))
      throw std::runtime_error(source + ": storage '" + request.key + "' has no record " + record +
                               " (truncated or damaged checkpoint)");
    std::size_t length = 0;
    const char* bytes = zip.data(record, &length);
    return storage_tensor(bytes, length, request, keep_alive, source);
  };
  std::size_t pickle_size = 0;
  const char* pickle = zip.data(prefix + kPickle, &pickle_size);
  return unpickle(pickle, pickle_size, load, source + " (" + prefix + kPickle + ")");
}

PickleValue read_torch_checkpoint(const std::string& path) {
  const auto mapped = std::make_shared<const MappedFile>(path, MappedFile::Access::kCopyOnWrite);
  return parse_torch_checkpoint(mapped->data(), mapped->size(), path, mapped);
}

WeightsFile checkpoint_weights(const PickleValue& checkpoint, const std::string& source) {
  if (!checkpoint.is(PickleValue::Kind::kDict))
    throw std::runtime_error(source + ": the checkpoint holds a " +
                             std::string(checkpoint.kind_name()) +
                             ", not a dict of weights (a state dict, or MoGe's "
                             "{'model_config', 'model'})");
  WeightsFile weights;
  const PickleValue* model = checkpoint.find("model");
  if (model != nullptr && model->is(PickleValue::Kind::kDict)) {
    const PickleValue* config = checkpoint.find("model_config");
    if (config == nullptr || !config->is(PickleValue::Kind::kDict))
      throw std::runtime_error(source +
                               ": has 'model' but no 'model_config' dict (expected MoGe's "
                               "layout)");
    weights.tensors = state_dict_of(*model, "'model'", source);
    weights.metadata["format"] = "moge2";
    weights.metadata["config"] =
        to_json(*config, "model_config", source)
            .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    return weights;
  }
  bool all_tensors = !checkpoint.keys().empty();
  for (const PickleValue& value : checkpoint.values())
    all_tensors = all_tensors && value.is(PickleValue::Kind::kTensor);
  if (!all_tensors) {
    std::string keys;
    for (std::size_t i = 0; i < checkpoint.keys().size() && i < 10; ++i) {
      const PickleValue& key = checkpoint.keys()[i];
      keys += (i ? ", " : "") +
              (key.is(PickleValue::Kind::kString) ? key.as_string() : key.kind_name());
    }
    throw std::runtime_error(source +
                             ": neither MoGe's {'model_config', 'model'} layout nor a state dict "
                             "(name -> tensor); top-level keys: " +
                             (keys.empty() ? "none" : keys));
  }
  weights.tensors = state_dict_of(checkpoint, "the state dict", source);
  weights.metadata["format"] = "state_dict";
  return weights;
}

WeightsFile read_weights(const std::string& path, std::optional<at::ScalarType> convert_to) {
  if (convert_to && !is_stored_float(*convert_to))
    throw std::invalid_argument(std::string("read_weights: cannot convert to ") +
                                c10::toString(*convert_to) + " (expected a floating-point type)");
  char head[16] = {};
  std::ifstream(path, std::ios::binary).read(head, sizeof head);
  WeightsFile weights;
  if (looks_like_zip(head, sizeof head) || looks_like_legacy_torch(head, sizeof head)) {
    weights = checkpoint_weights(read_torch_checkpoint(path), path);
  } else {  // safetensors, or its parser's error for whatever else the file is
    const auto mapped = std::make_shared<const MappedFile>(path, MappedFile::Access::kCopyOnWrite);
    SafetensorsFile file = parse_safetensors(mapped->data(), mapped->size(), path, mapped);
    weights.tensors = std::move(file.tensors);
    weights.metadata = std::move(file.metadata);
  }
  for (auto& [name, tensor] : weights.tensors) {
    if (convert_to && is_stored_float(tensor.scalar_type())) tensor = tensor.to(*convert_to);
    tensor = tensor.contiguous();
  }
  return weights;
}

}  // namespace omnipoint::io
