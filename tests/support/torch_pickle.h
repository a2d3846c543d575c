#pragma once
// Hand-built PyTorch checkpoints for the tests: pickle opcodes as torch.save writes them
// (protocol 2) and a stored zip in torch.save's layout (records aligned to 64 bytes), so the
// checkpoint reader is tested without Python, byte by byte.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace omnipoint::test {

inline std::string le(std::uint64_t value, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((value >> (8 * i)) & 0xff);
  return out;
}

// Pickle pieces (each pushes one value).
inline std::string pkl_str(const std::string& text) {
  return "X" + le(text.size(), 4) + text;
}
inline std::string pkl_int(std::int32_t value) {
  return "J" + le(static_cast<std::uint32_t>(value), 4);
}
inline std::string pkl_global(const std::string& module, const std::string& name) {
  return "c" + module + "\n" + name + "\n";
}
inline std::string pkl_tuple(const std::vector<std::string>& items) {
  std::string out = "(";
  for (const std::string& item : items) out += item;
  return out + "t";
}
inline std::string pkl_int_tuple(const std::vector<std::int32_t>& values) {
  std::vector<std::string> items;
  for (const std::int32_t v : values) items.push_back(pkl_int(v));
  return pkl_tuple(items);
}
inline std::string pkl_ordered_dict() {
  return pkl_global("collections", "OrderedDict") + ")R";
}
// torch._utils._rebuild_tensor_v2 over storage `key` of `numel` elements of `storage_type`.
inline std::string pkl_tensor(const std::string& key, const std::string& storage_type,
                              std::int32_t numel, std::int32_t offset,
                              const std::vector<std::int32_t>& sizes,
                              const std::vector<std::int32_t>& strides) {
  const std::string pid = pkl_tuple({pkl_str("storage"), pkl_global("torch", storage_type),
                                     pkl_str(key), pkl_str("cpu"), pkl_int(numel)});
  return pkl_global("torch._utils", "_rebuild_tensor_v2") +
         pkl_tuple({pid + "Q", pkl_int(offset), pkl_int_tuple(sizes), pkl_int_tuple(strides),
                    "\x89", pkl_ordered_dict()}) +
         "R";
}
// A whole pickle: PROTO 2, an OrderedDict of the named values (SETITEMS), STOP.
inline std::string pkl_state_dict(const std::vector<std::pair<std::string, std::string>>& items) {
  std::string out = std::string("\x80\x02", 2) + pkl_ordered_dict() + "(";
  for (const auto& [name, value] : items) out += pkl_str(name) + value;
  return out + "u.";
}

// A stored zip of the entries, each entry's data aligned to 64 bytes as torch.save does.
inline std::string stored_zip(const std::vector<std::pair<std::string, std::string>>& entries) {
  std::string out, directory;
  for (const auto& [name, data] : entries) {
    const std::size_t header_at = out.size();
    const std::size_t unpadded = header_at + 30 + name.size() + 4;
    const std::size_t padding = (64 - unpadded % 64) % 64;
    const std::string extra = le(0x1234, 2) + le(padding, 2) + std::string(padding, 'Z');
    const std::string sizes = le(0, 4) + le(data.size(), 4) + le(data.size(), 4);  // crc unused
    out += le(0x04034b50, 4) + le(20, 2) + le(0, 2) + le(0, 2) + le(0, 4) + sizes +
           le(name.size(), 2) + le(extra.size(), 2) + name + extra + data;
    directory += le(0x02014b50, 4) + le(20, 2) + le(20, 2) + le(0, 2) + le(0, 2) + le(0, 4) +
                 sizes + le(name.size(), 2) + le(0, 2) + le(0, 2) + le(0, 2) + le(0, 2) + le(0, 4) +
                 le(header_at, 4) + name;
  }
  const std::size_t directory_at = out.size();
  out += directory;
  out += le(0x06054b50, 4) + le(0, 2) + le(0, 2) + le(entries.size(), 2) + le(entries.size(), 2) +
         le(directory.size(), 4) + le(directory_at, 4) + le(0, 2);
  return out;
}

// A checkpoint of the pickle and its storages (key -> bytes) under "archive/".
inline std::string checkpoint_zip(
    const std::string& pickle, const std::vector<std::pair<std::string, std::string>>& storages) {
  std::vector<std::pair<std::string, std::string>> entries = {{"archive/data.pkl", pickle}};
  for (const auto& [key, bytes] : storages) entries.emplace_back("archive/data/" + key, bytes);
  entries.emplace_back("archive/version", "3\n");
  return stored_zip(entries);
}

}  // namespace omnipoint::test
