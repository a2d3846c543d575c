#include "omnipoint/io/glb.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/io/atomic_file.h"

namespace omnipoint::io {

namespace {

using json = nlohmann::json;

constexpr uint32_t kMagic = 0x46546C67;      // "glTF"
constexpr uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
constexpr uint32_t kBinChunk = 0x004E4942;   // "BIN\0"
constexpr int kFloat = 5126, kUnsignedByte = 5121, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kPoints = 0, kTriangles = 4;

void append_u32(std::string& out, uint32_t value) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
}

// `count` little-endian 32-bit words word(0), word(1), ... through one reused block: the BIN
// chunk of a 12 MP mesh is ~450 MB, not worth a copy in memory.
template <typename Word>
void write_words(std::ostream& out, int64_t count, const Word& word) {
  constexpr int64_t kBlock = 65536;
  std::vector<uint32_t> block(static_cast<size_t>(std::min(kBlock, count)));
  for (int64_t first = 0; first < count; first += kBlock) {
    const int64_t size = std::min(kBlock, count - first);
    for (int64_t i = 0; i < size; ++i) block[i] = word(first + i);
    out.write(reinterpret_cast<const char*>(block.data()), static_cast<std::streamsize>(size * 4));
  }
}

// faces: (T, 3) integer indices, or undefined for a point cloud. Every array is a multiple
// of 4 bytes long, so the BIN chunk needs no padding between or after them.
void encode(const at::Tensor& points, const at::Tensor& colors, const at::Tensor& face_indices,
            std::ostream& out) {
  if (points.dim() != 2 || points.size(1) != 3 || !at::isFloatingType(points.scalar_type()))
    throw std::invalid_argument("glb: points must be floating (N, 3), got " +
                                c10::str(points.sizes()));
  const int64_t count = points.size(0);
  if (colors.defined() && (colors.scalar_type() != at::kByte || colors.sizes() != points.sizes()))
    throw std::invalid_argument("glb: colors must be uint8 (N, 3) like the points");
  const at::Tensor xyz = points.to(at::kCPU, at::kFloat).contiguous();
  const at::Tensor rgb = colors.defined() ? colors.to(at::kCPU).contiguous() : at::Tensor();
  // glTF: y up, looking along -z. The bounds and the check first, the positions written into
  // the file's buffer below.
  const float flip[3] = {1.0f, -1.0f, -1.0f};
  std::vector<float> low(3, std::numeric_limits<float>::infinity()),
      high(3, -std::numeric_limits<float>::infinity());
  const float* source = xyz.data_ptr<float>();
  for (int64_t i = 0; i < 3 * count; ++i) {
    const float value = source[i] * flip[i % 3];
    if (!std::isfinite(value)) throw std::invalid_argument("glb: points must be finite");
    low[i % 3] = std::min(low[i % 3], value);
    high[i % 3] = std::max(high[i % 3], value);
  }
  // Checked here, written as uint32 below: every index of a GLB under 4 GiB (< 2^28 vertices)
  // fits.
  const at::Tensor faces =
      face_indices.defined() ? face_indices.to(at::kCPU).contiguous() : at::Tensor();
  const int64_t index_count = faces.defined() ? faces.numel() : 0;
  if (index_count > 0)
    AT_DISPATCH_INTEGRAL_TYPES(faces.scalar_type(), "glb", [&] {
      const scalar_t* index = faces.data_ptr<scalar_t>();
      for (int64_t i = 0; i < index_count; ++i) {
        const int64_t value = index[i];
        if (value < 0 || value >= count)
          throw std::invalid_argument("glb: face indices must lie in [0, " + std::to_string(count) +
                                      ")");
      }
    });
  const int64_t position_bytes = count * 12, color_bytes = count * 4, index_bytes = index_count * 4;
  const int64_t bin_bytes = position_bytes + color_bytes + index_bytes;
  json gltf;
  gltf["asset"] = {{"version", "2.0"}, {"generator", "omnipoint"}};
  gltf["scene"] = 0;
  gltf["scenes"] = json::array({json{{"nodes", json::array({0})}}});
  const bool empty = count == 0 || (faces.defined() && index_count == 0);
  if (empty) {
    gltf["nodes"] = json::array({json{{"name", "omnipoint"}}});
  } else {
    gltf["nodes"] = json::array({json{{"name", "omnipoint"}, {"mesh", 0}}});
    json primitive = {{"attributes", {{"POSITION", 0}, {"COLOR_0", 1}}},
                      {"mode", faces.defined() ? kTriangles : kPoints}};
    gltf["accessors"] = json::array({json{{"bufferView", 0},
                                          {"componentType", kFloat},
                                          {"count", count},
                                          {"type", "VEC3"},
                                          {"min", low},
                                          {"max", high}},
                                     json{{"bufferView", 1},
                                          {"componentType", kUnsignedByte},
                                          {"normalized", true},
                                          {"count", count},
                                          {"type", "VEC4"}}});
    gltf["bufferViews"] = json::array({json{{"buffer", 0},
                                            {"byteOffset", 0},
                                            {"byteLength", position_bytes},
                                            {"target", kArrayBuffer}},
                                       json{{"buffer", 0},
                                            {"byteOffset", position_bytes},
                                            {"byteLength", color_bytes},
                                            {"target", kArrayBuffer}}});
    if (faces.defined()) {
      primitive["indices"] = 2;
      primitive["material"] = 0;
      gltf["accessors"].push_back({{"bufferView", 2},
                                   {"componentType", kUnsignedInt},
                                   {"count", index_count},
                                   {"type", "SCALAR"}});
      gltf["bufferViews"].push_back({{"buffer", 0},
                                     {"byteOffset", position_bytes + color_bytes},
                                     {"byteLength", index_bytes},
                                     {"target", kElementArrayBuffer}});
      // The default material is metallic (black without an environment) and single-sided.
      gltf["materials"] = json::array(
          {json{{"pbrMetallicRoughness", {{"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}},
                {"doubleSided", true}}});
    }
    gltf["meshes"] = json::array({json{{"primitives", json::array({primitive})}}});
    gltf["buffers"] = json::array({json{{"byteLength", bin_bytes}}});
  }
  std::string text = gltf.dump();
  text.append((4 - text.size() % 4) % 4, ' ');

  const size_t total = 12 + 8 + text.size() + (empty ? 0 : 8 + bin_bytes);
  if (total > UINT32_MAX) throw std::invalid_argument("glb: the data exceeds the 4 GiB GLB limit");
  std::string head;
  append_u32(head, kMagic);
  append_u32(head, 2);
  append_u32(head, static_cast<uint32_t>(total));
  append_u32(head, static_cast<uint32_t>(text.size()));
  append_u32(head, kJsonChunk);
  head += text;
  if (!empty) {
    append_u32(head, static_cast<uint32_t>(bin_bytes));
    append_u32(head, kBinChunk);
  }
  out.write(head.data(), static_cast<std::streamsize>(head.size()));
  if (empty) return;
  write_words(out, 3 * count, [&](int64_t i) {
    const float value = source[i] * flip[i % 3];
    uint32_t word = 0;
    std::memcpy(&word, &value, 4);
    return word;
  });
  // RGBA, opaque; white without colours.
  const uint8_t* color = rgb.defined() ? rgb.data_ptr<uint8_t>() : nullptr;
  write_words(out, count, [&](int64_t i) {
    uint32_t word = 0xFF000000u;
    for (int c = 0; c < 3; ++c)
      word |= static_cast<uint32_t>(color != nullptr ? color[3 * i + c] : 255) << (8 * c);
    return word;
  });
  if (index_count > 0)
    AT_DISPATCH_INTEGRAL_TYPES(faces.scalar_type(), "glb", [&] {
      const scalar_t* index = faces.data_ptr<scalar_t>();
      write_words(out, index_count, [&](int64_t i) { return static_cast<uint32_t>(index[i]); });
    });
}

std::string encode_to_string(const at::Tensor& points, const at::Tensor& colors,
                             const at::Tensor& faces) {
  std::ostringstream out;
  encode(points, colors, faces, out);
  return out.str();
}

}  // namespace

std::string encode_glb_points(const at::Tensor& points, const at::Tensor& colors) {
  return encode_to_string(points, colors, {});
}

void write_glb_points(const std::string& path, const at::Tensor& points, const at::Tensor& colors) {
  write_file_atomically(path, [&](std::ostream& out) { encode(points, colors, {}, out); });
}

namespace {
void check_faces(const at::Tensor& faces) {
  if (!faces.defined() || faces.dim() != 2 || faces.size(1) != 3 ||
      !at::isIntegralType(faces.scalar_type(), /*includeBool=*/false))
    throw std::invalid_argument("glb: faces must be integer (T, 3)");
}
}  // namespace

std::string encode_glb_mesh(const at::Tensor& vertices, const at::Tensor& colors,
                            const at::Tensor& faces) {
  check_faces(faces);
  return encode_to_string(vertices, colors, faces);
}

void write_glb_mesh(const std::string& path, const at::Tensor& vertices, const at::Tensor& colors,
                    const at::Tensor& faces) {
  check_faces(faces);
  write_file_atomically(path, [&](std::ostream& out) { encode(vertices, colors, faces, out); });
}

}  // namespace omnipoint::io
