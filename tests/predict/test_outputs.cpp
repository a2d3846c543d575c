// The output writers on the oracle path: a synth sample's ground-truth rays and distances fed
// through write_prediction_outputs, then every file read back and checked against them.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/fit.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/glb.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"
#include "support/fast_synth.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

data::synth::SynthSample render(const std::string& spec, uint64_t seed = 3) {
  return data::synth::synthesize(data::synth::SceneKind::kIndoor, seed, camera::parse_camera(spec),
                                 test::fast_synth());
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("omnipoint_predict_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

uint32_t u32_at(const std::string& bytes, size_t offset) {
  uint32_t value;
  std::memcpy(&value, bytes.data() + offset, 4);
  return value;
}

TEST(PredictOutputs, OracleFilesRoundTrip) {
  const data::synth::SynthSample synth = render("PINHOLE 64 48 52 52 32 24");
  const Prediction p =
      prediction_from_geometry(synth.rays, synth.sample.distance, synth.sample.mask);
  const fs::path folder = fresh_dir("oracle") / "sample";
  write_prediction_outputs(folder.string(), synth.sample.image, p);

  const at::Tensor expected_points = synth.rays * synth.sample.distance.unsqueeze(-1);
  const at::Tensor mask = synth.sample.mask;
  ASSERT_GT(mask.sum().item<int64_t>(), 1000);
  // npy: distance, rays and depth as given; points = d·r.
  EXPECT_TRUE(at::equal(io::read_npy((folder / "points.npy").string()), p.points));
  EXPECT_TRUE(at::equal(io::read_npy((folder / "distance.npy").string()), p.distance));
  EXPECT_TRUE(at::equal(io::read_npy((folder / "rays.npy").string()), p.rays));
  const at::Tensor depth = io::read_npy((folder / "depth.npy").string());
  EXPECT_TRUE(at::allclose(depth.masked_select(mask), synth.depth.masked_select(mask), 1e-5, 1e-5));
  // PLY: the valid points, in row-major pixel order, with the image's colours.
  const io::PlyPoints ply = io::read_ply((folder / "points.ply").string());
  const at::Tensor valid_points = expected_points.view({-1, 3}).index({mask.view(-1)});
  ASSERT_EQ(ply.points.size(0), valid_points.size(0));
  EXPECT_TRUE(at::allclose(ply.points, valid_points, 1e-6, 1e-6));
  EXPECT_TRUE(at::equal(
      ply.colors,
      synth.sample.image.view({-1, 3}).index({mask.view(-1)}).mul(255).round().to(at::kByte)));
  // npy round trip: points from distance.npy and rays.npy are the PLY's.
  const at::Tensor from_npy = io::read_npy((folder / "rays.npy").string()) *
                              io::read_npy((folder / "distance.npy").string()).unsqueeze(-1);
  EXPECT_TRUE(at::allclose(from_npy.view({-1, 3}).index({mask.view(-1)}), ply.points, 1e-6, 1e-6));
  // depth.png in millimetres, mask.png 255 where valid.
  const at::Tensor depth_mm = io::read_image_values((folder / "depth.png").string());
  EXPECT_LE((depth_mm.masked_select(mask) / 1000 - synth.depth.masked_select(mask))
                .abs()
                .max()
                .item<float>(),
            0.0006);
  EXPECT_TRUE(at::equal(io::read_image_values((folder / "mask.png").string()) > 0, mask));
  EXPECT_EQ(io::read_image((folder / "preview.png").string()).size(2), 3);
  EXPECT_EQ(io::read_image((folder / "depth_vis.png").string()).sizes(),
            synth.sample.image.sizes());
  const auto json = nlohmann::json::parse(io::read_file((folder / "camera.json").string()));
  EXPECT_EQ(json["valid_pixels"].get<int64_t>(), mask.sum().item<int64_t>());
  EXPECT_TRUE(json["timing_ms"].contains("writing"));
  // No staging folder left beside the output.
  for (const auto& entry : fs::directory_iterator(folder.parent_path()))
    EXPECT_EQ(entry.path().filename(), "sample");

  // GLB: header, 4-byte aligned chunks, accessor counts, positions (x, -y, -z).
  const std::string glb = io::read_file((folder / "points.glb").string());
  ASSERT_GE(glb.size(), 28u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  EXPECT_EQ(u32_at(glb, 4), 2u);
  EXPECT_EQ(u32_at(glb, 8), glb.size());
  const uint32_t json_length = u32_at(glb, 12);
  EXPECT_EQ(u32_at(glb, 16), 0x4E4F534Au);
  EXPECT_EQ(json_length % 4, 0u);
  const auto gltf = nlohmann::json::parse(glb.substr(20, json_length));
  const size_t bin_header = 20 + json_length;
  const uint32_t bin_length = u32_at(glb, bin_header);
  EXPECT_EQ(u32_at(glb, bin_header + 4), 0x004E4942u);
  EXPECT_EQ(bin_length % 4, 0u);
  EXPECT_EQ(bin_header + 8 + bin_length, glb.size());
  EXPECT_EQ(gltf["asset"]["version"], "2.0");
  EXPECT_EQ(gltf["meshes"][0]["primitives"][0]["mode"], 0);
  const int64_t count = valid_points.size(0);
  EXPECT_EQ(gltf["accessors"][0]["count"].get<int64_t>(), count);
  EXPECT_EQ(gltf["accessors"][1]["count"].get<int64_t>(), count);
  EXPECT_EQ(gltf["bufferViews"][0]["byteLength"].get<int64_t>(), count * 12);
  EXPECT_EQ(gltf["buffers"][0]["byteLength"].get<uint32_t>(), bin_length);
  at::Tensor positions = at::empty({count, 3}, at::kFloat);
  std::memcpy(positions.data_ptr<float>(), glb.data() + bin_header + 8, count * 12);
  EXPECT_TRUE(at::allclose(positions, valid_points * at::tensor({1.0f, -1.0f, -1.0f}), 1e-6, 1e-6));
}

TEST(PredictOutputs, EmptyCloudGlbIsValid) {
  const std::string glb = io::encode_glb_points(at::zeros({0, 3}));
  EXPECT_EQ(u32_at(glb, 8), glb.size());
  EXPECT_EQ(glb.size(), 20 + u32_at(glb, 12));
  EXPECT_FALSE(nlohmann::json::parse(glb.substr(20))["nodes"][0].contains("mesh"));
}

// The camera fitted to the rays of a known camera is that camera (the "predicted rays" are
// exact here). Which model "auto" picks: tests/camera/test_auto_fit.cpp.
TEST(PredictOutputs, FittedCameraRecoversTheCamera) {
  for (const std::string spec :
       {"PINHOLE 64 48 52 50 31 25", "OPENCV_FISHEYE 64 64 26 26 32 32 0.02 -0.01 0 0"}) {
    const camera::Camera truth = camera::parse_camera(spec);
    const camera::Rays rays = truth.ray_map();
    const at::Tensor distance = at::full({truth.height(), truth.width()}, 2.0);
    const Prediction p = prediction_from_geometry(rays.rays, distance, rays.valid);
    const camera::Camera fitted =
        camera::fit_camera(truth.model_name(), truth.width(), truth.height(), p.rays, p.mask);
    ASSERT_EQ(fitted.params().size(), truth.params().size());
    for (size_t i = 0; i < 4; ++i) EXPECT_NEAR(fitted.params()[i], truth.params()[i], 1e-3) << spec;
    // And the fitted camera's rays are the given ones.
    const at::Tensor angle_cos =
        (fitted.ray_map(at::kDouble).rays * truth.ray_map(at::kDouble).rays)
            .sum(-1)
            .masked_select(rays.valid);
    EXPECT_GT(angle_cos.min().item<double>(), std::cos(1e-4)) << spec;
  }
}

}  // namespace
}  // namespace omnipoint::predict
