// GLB triangle meshes parsed back: the container (header, chunk types and lengths, 4-byte
// alignment), the glTF JSON the spec requires (accessor min/max, component types, targets)
// and the BIN data (positions flipped to glTF's y up, RGBA colours, uint32 indices).
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/glb.h"
#include "support/glb_chunks.h"

namespace omnipoint::io {
namespace {

using test::GlbChunks;
using test::parse_glb;

template <typename T>
at::Tensor view_at(const GlbChunks& glb, const nlohmann::json& accessor, int64_t columns,
                   at::ScalarType dtype) {
  const nlohmann::json& view = glb.gltf["bufferViews"][accessor["bufferView"].get<int>()];
  const int64_t count = accessor["count"].get<int64_t>();
  EXPECT_EQ(view["byteLength"].get<int64_t>(), count * columns * int64_t(sizeof(T)));
  EXPECT_EQ(view["byteOffset"].get<int64_t>() % 4, 0);
  at::Tensor out = at::empty({count, columns}, dtype);
  std::memcpy(out.data_ptr(), glb.bin.data() + view["byteOffset"].get<int64_t>(),
              count * columns * sizeof(T));
  return out;
}

TEST(GlbMesh, ParsesBackToTheMesh) {
  // Two triangles of a unit square at z = 2 (camera frame), and one lone vertex they skip.
  const at::Tensor vertices =
      at::tensor({0.f, 0.f, 2.f, 0.f, 1.f, 2.f, 1.f, 0.f, 2.f, 1.f, 1.f, 2.f, 5.f, 5.f, 5.f})
          .view({5, 3});
  const at::Tensor colors = at::arange(15, at::kByte).view({5, 3});
  const at::Tensor faces = at::tensor({0, 1, 2, 2, 1, 3}, at::kLong).view({2, 3});
  const GlbChunks glb = parse_glb(encode_glb_mesh(vertices, colors, faces));
  const auto& gltf = glb.gltf;
  EXPECT_EQ(gltf["asset"]["version"], "2.0");
  const auto& primitive = gltf["meshes"][0]["primitives"][0];
  EXPECT_EQ(primitive["mode"], 4);
  const auto& position = gltf["accessors"][primitive["attributes"]["POSITION"].get<int>()];
  const auto& color = gltf["accessors"][primitive["attributes"]["COLOR_0"].get<int>()];
  const auto& index = gltf["accessors"][primitive["indices"].get<int>()];
  EXPECT_EQ(position["componentType"], 5126);
  EXPECT_EQ(position["min"], nlohmann::json({0.0, -5.0, -5.0}));
  EXPECT_EQ(position["max"], nlohmann::json({5.0, 0.0, -2.0}));
  EXPECT_EQ(color["componentType"], 5121);
  EXPECT_TRUE(color["normalized"].get<bool>());
  EXPECT_EQ(index["componentType"], 5125);
  EXPECT_EQ(index["type"], "SCALAR");
  EXPECT_EQ(index["count"], 6);
  EXPECT_EQ(gltf["bufferViews"][index["bufferView"].get<int>()]["target"], 34963);
  EXPECT_TRUE(gltf["materials"][primitive["material"].get<int>()]["doubleSided"].get<bool>());
  EXPECT_EQ(gltf["buffers"][0]["byteLength"].get<size_t>(), glb.bin.size());
  EXPECT_TRUE(at::equal(view_at<float>(glb, position, 3, at::kFloat),
                        vertices * at::tensor({1.f, -1.f, -1.f})));
  EXPECT_TRUE(at::equal(view_at<uint8_t>(glb, color, 4, at::kByte),
                        at::cat({colors, at::full({5, 1}, 255, at::kByte)}, 1)));
  EXPECT_TRUE(
      at::equal(view_at<int32_t>(glb, index, 1, at::kInt).view({2, 3}), faces.to(at::kInt)));

  // Written atomically, the same bytes.
  const auto path = std::filesystem::temp_directory_path() / "omnipoint_io_mesh.glb";
  write_glb_mesh(path.string(), vertices, colors, faces);
  EXPECT_EQ(read_file(path.string()), encode_glb_mesh(vertices, colors, faces));
  std::filesystem::remove(path);
}

TEST(GlbMesh, NoTrianglesGivesAnEmptyScene) {
  const GlbChunks glb =
      parse_glb(encode_glb_mesh(at::zeros({4, 3}), {}, at::zeros({0, 3}, at::kInt)));
  EXPECT_FALSE(glb.gltf["nodes"][0].contains("mesh"));
  EXPECT_TRUE(glb.bin.empty());
}

TEST(GlbMesh, BadFacesSaySo) {
  const at::Tensor vertices = at::zeros({3, 3});
  const auto message = [&](const at::Tensor& faces) {
    try {
      encode_glb_mesh(vertices, {}, faces);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(at::tensor({0, 1, 3}, at::kInt).view({1, 3})),
            "glb: face indices must lie in [0, 3)");
  EXPECT_EQ(message(at::tensor({0, -1, 2}, at::kInt).view({1, 3})),
            "glb: face indices must lie in [0, 3)");
  EXPECT_EQ(message(at::zeros({2, 4}, at::kInt)), "glb: faces must be integer (T, 3)");
  EXPECT_EQ(message(at::zeros({1, 3})), "glb: faces must be integer (T, 3)");
}

}  // namespace
}  // namespace omnipoint::io
