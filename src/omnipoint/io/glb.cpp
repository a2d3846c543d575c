#include "omnipoint/io/glb.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <ostream>
#include <stdexcept>

#include "omnipoint/io/atomic_file.h"

namespace omnipoint::io {

namespace {

constexpr uint32_t kMagic = 0x46546C67;      // "glTF"
constexpr uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
constexpr uint32_t kBinChunk = 0x004E4942;   // "BIN\0"
constexpr int kFloat = 5126, kUnsignedByte = 5121, kArrayBuffer = 34962, kPoints = 0;

void append_u32(std::string& out, uint32_t value) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
}

}  // namespace

std::string encode_glb_points(const at::Tensor& points, const at::Tensor& colors) {
  if (points.dim() != 2 || points.size(1) != 3 || !at::isFloatingType(points.scalar_type()))
    throw std::invalid_argument("glb: points must be floating (N, 3), got " +
                                c10::str(points.sizes()));
  const int64_t count = points.size(0);
  if (colors.defined() && (colors.scalar_type() != at::kByte || colors.sizes() != points.sizes()))
    throw std::invalid_argument("glb: colors must be uint8 (N, 3) like the points");
  // glTF: y up, looking along -z.
  const at::Tensor positions =
      (points.to(at::kCPU, at::kFloat) * at::tensor({1.0f, -1.0f, -1.0f})).contiguous();
  if (!at::isfinite(positions).all().item<bool>())
    throw std::invalid_argument("glb: points must be finite");
  const at::Tensor rgb =
      colors.defined() ? colors.to(at::kCPU) : at::full({count, 3}, 255, at::kByte);
  const at::Tensor rgba = at::cat({rgb, at::full({count, 1}, 255, at::kByte)}, 1).contiguous();

  const int64_t position_bytes = count * 12, color_bytes = count * 4;
  std::string bin(static_cast<size_t>(position_bytes + color_bytes), '\0');
  if (count > 0) {
    std::memcpy(bin.data(), positions.data_ptr<float>(), position_bytes);
    std::memcpy(bin.data() + position_bytes, rgba.data_ptr<uint8_t>(), color_bytes);
  }

  nlohmann::json gltf;
  gltf["asset"] = {{"version", "2.0"}, {"generator", "omnipoint"}};
  gltf["scene"] = 0;
  gltf["scenes"] = nlohmann::json::array({nlohmann::json{{"nodes", nlohmann::json::array({0})}}});
  if (count == 0) {
    gltf["nodes"] = nlohmann::json::array({nlohmann::json{{"name", "omnipoint"}}});
  } else {
    const at::Tensor low = std::get<0>(positions.min(0)), high = std::get<0>(positions.max(0));
    const auto vec = [](const at::Tensor& t) {
      return std::vector<float>{t[0].item<float>(), t[1].item<float>(), t[2].item<float>()};
    };
    using json = nlohmann::json;
    gltf["nodes"] = json::array({json{{"name", "omnipoint"}, {"mesh", 0}}});
    const json attributes = {{"POSITION", 0}, {"COLOR_0", 1}};
    const json primitive = {{"attributes", attributes}, {"mode", kPoints}};
    gltf["meshes"] = json::array({json{{"primitives", json::array({primitive})}}});
    gltf["accessors"] = json::array({json{{"bufferView", 0},
                                          {"componentType", kFloat},
                                          {"count", count},
                                          {"type", "VEC3"},
                                          {"min", vec(low)},
                                          {"max", vec(high)}},
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
    gltf["buffers"] = json::array({json{{"byteLength", bin.size()}}});
  }
  std::string json = gltf.dump();
  json.append((4 - json.size() % 4) % 4, ' ');
  bin.append((4 - bin.size() % 4) % 4, '\0');  // already aligned (12 and 4 bytes per point)

  const bool with_bin = count > 0;
  const size_t total = 12 + 8 + json.size() + (with_bin ? 8 + bin.size() : 0);
  if (total > UINT32_MAX)
    throw std::invalid_argument("glb: the point cloud exceeds the 4 GiB GLB limit");
  std::string out;
  out.reserve(total);
  append_u32(out, kMagic);
  append_u32(out, 2);
  append_u32(out, static_cast<uint32_t>(total));
  append_u32(out, static_cast<uint32_t>(json.size()));
  append_u32(out, kJsonChunk);
  out += json;
  if (with_bin) {
    append_u32(out, static_cast<uint32_t>(bin.size()));
    append_u32(out, kBinChunk);
    out += bin;
  }
  return out;
}

void write_glb_points(const std::string& path, const at::Tensor& points, const at::Tensor& colors) {
  const std::string bytes = encode_glb_points(points, colors);
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
}

}  // namespace omnipoint::io
