// The output writers on the oracle path: a synth sample's ground-truth rays and distances fed
// through write_prediction_outputs, then every file read back and checked against them.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/fit.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/geometry/grid_surface.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/glb.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"
#include "support/fast_synth.h"
#include "support/glb_chunks.h"
#include "support/thread_count.h"

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

using test::u32_at;

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
  // distance.png in 1/256 m, within half a unit; normals.npy the point map's normals.
  const at::Tensor distance_units = io::read_image_values((folder / "distance.png").string());
  EXPECT_LE((distance_units.masked_select(mask) / 256 - synth.sample.distance.masked_select(mask))
                .abs()
                .max()
                .item<float>(),
            0.5 / 256 + 1e-6);
  EXPECT_TRUE(at::equal(io::read_npy((folder / "normals.npy").string()),
                        geometry::normals_from_point_map(p.points, p.mask).normals));
  EXPECT_EQ(io::read_image((folder / "preview.png").string()).size(2), 3);
  // image.png: the input's 8-bit RGB.
  EXPECT_TRUE(at::equal(io::read_image_values((folder / "image.png").string()),
                        synth.sample.image.mul(255).round()));
  EXPECT_EQ(io::read_image((folder / "depth_vis.png").string()).sizes(),
            synth.sample.image.sizes());
  const auto json = nlohmann::json::parse(io::read_file((folder / "camera.json").string()));
  EXPECT_EQ(json["valid_pixels"].get<int64_t>(), mask.sum().item<int64_t>());
  EXPECT_TRUE(json["timing_ms"].contains("writing"));
  // The default files, each timed; no mesh unless asked for.
  const std::set<std::string> files = default_output_files();
  EXPECT_EQ(json["files"].get<std::set<std::string>>(), files);
  EXPECT_EQ(files.count("mesh.glb"), 0u);
  for (const std::string& file : files) {
    EXPECT_TRUE(fs::is_regular_file(folder / file)) << file;
    EXPECT_EQ(json["timing_ms"]["files"].contains(file), file != "camera.json") << file;
  }
  // No staging folder left beside the output.
  for (const auto& entry : fs::directory_iterator(folder.parent_path()))
    EXPECT_EQ(entry.path().filename(), "sample");

  // GLB: header, 4-byte aligned chunks, accessor counts, positions (x, -y, -z).
  const std::string glb = io::read_file((folder / "points.glb").string());
  const test::GlbChunks chunks = test::parse_glb(glb);
  const nlohmann::json& gltf = chunks.gltf;
  EXPECT_EQ(gltf["asset"]["version"], "2.0");
  EXPECT_EQ(gltf["meshes"][0]["primitives"][0]["mode"], 0);
  const int64_t count = valid_points.size(0);
  EXPECT_EQ(gltf["accessors"][0]["count"].get<int64_t>(), count);
  EXPECT_EQ(gltf["accessors"][1]["count"].get<int64_t>(), count);
  EXPECT_EQ(gltf["bufferViews"][0]["byteLength"].get<int64_t>(), count * 12);
  EXPECT_EQ(gltf["buffers"][0]["byteLength"].get<size_t>(), chunks.bin.size());
  ASSERT_GE(chunks.bin.size(), size_t(count * 12));
  at::Tensor positions = at::empty({count, 3}, at::kFloat);
  std::memcpy(positions.data_ptr<float>(), chunks.bin.data(), count * 12);
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

std::set<std::string> files_in(const fs::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.insert(entry.path().filename());
  return names;
}

nlohmann::json camera_json(const fs::path& folder) {
  return nlohmann::json::parse(io::read_file((folder / "camera.json").string()));
}

TEST(OutputList, GroupsAndFileNames) {
  using Files = std::set<std::string>;
  EXPECT_EQ(parse_output_list("ply,mesh"), (Files{"camera.json", "mesh.glb", "points.ply"}));
  EXPECT_EQ(parse_output_list("camera"), Files{"camera.json"});
  EXPECT_EQ(parse_output_list("npy,depth.png"),
            (Files{"camera.json", "depth.npy", "depth.png", "distance.npy", "normals.npy",
                   "points.npy", "rays.npy"}));
  EXPECT_EQ(parse_output_list("depth,vis"),
            (Files{"camera.json", "depth.png", "depth_vis.png", "distance.png"}));
  const Files defaults = {"camera.json",  "depth.npy",    "depth.png",  "depth_vis.png",
                          "distance.npy", "distance.png", "image.png",  "mask.png",
                          "normals.npy",  "points.glb",   "points.npy", "points.ply",
                          "preview.png",  "rays.npy"};
  EXPECT_EQ(default_output_files(), defaults);
  EXPECT_EQ(parse_output_list("default"), defaults);
  Files all = defaults;
  all.insert("mesh.glb");
  EXPECT_EQ(parse_output_list("all"), all);
  EXPECT_EQ(parse_output_list("png,glb"),
            (Files{"camera.json", "depth.png", "depth_vis.png", "distance.png", "image.png",
                   "mask.png", "points.glb", "preview.png"}));
}

TEST(OutputList, BadNamesListTheValidOnes) {
  const auto message = [](const std::string& list) {
    try {
      parse_output_list(list);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string unknown = message("ply,exr");
  EXPECT_EQ(
      unknown.rfind("outputs: unknown name \"exr\" in \"ply,exr\"; valid: ply, glb, npy, depth, "
                    "mask, vis, preview, image, png, mesh, camera, default, all, or a file name "
                    "(camera.json, depth.npy, ",
                    0),
      0u)
      << unknown;
  EXPECT_NE(unknown.find("rays.npy)"), std::string::npos) << unknown;
  EXPECT_EQ(message("ply,,glb").rfind("outputs: an empty name in \"ply,,glb\"", 0), 0u);
  EXPECT_EQ(message("").rfind("outputs: an empty name", 0), 0u);
  // A hand-made OutputOptions with a name that is no file.
  OutputOptions options;
  options.files = {"points.exr"};
  const Prediction p = prediction_from_geometry(at::zeros({2, 2, 3}), at::zeros({2, 2}),
                                                at::zeros({2, 2}, at::kBool));
  const fs::path folder = fresh_dir("bad_file") / "sample";
  try {
    write_prediction_outputs(folder.string(), at::zeros({2, 2, 3}), p, options);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "outputs: unknown file \"points.exr\"");
  }
  EXPECT_FALSE(fs::exists(folder));
}

// A pinhole 8x6 view of a step: 2 m in image columns 0..3, 3 m in columns 4..7.
Prediction step_prediction() {
  const camera::Rays rays = camera::parse_camera("PINHOLE 8 6 8 8 4 3").ray_map();
  at::Tensor distance = at::full({6, 8}, 2.0f);
  distance.slice(1, 4).fill_(3.0f);
  return prediction_from_geometry(rays.rays, distance, rays.valid);
}

TEST(PredictOutputs, SelectionWritesExactlyTheChosenFiles) {
  const Prediction p = step_prediction();
  const at::Tensor image = at::rand({6, 8, 3});
  for (const std::string list : {"ply,mesh", "camera", "npy,vis", "all"}) {
    OutputOptions options;
    options.files = parse_output_list(list);
    const fs::path folder = fresh_dir("selection") / "sample";
    write_prediction_outputs(folder.string(), image, p, options);
    EXPECT_EQ(files_in(folder), options.files) << list;
    const auto json = camera_json(folder);
    EXPECT_EQ(json["files"].get<std::set<std::string>>(), options.files) << list;
    std::set<std::string> timed;
    for (const auto& [file, ms] : json["timing_ms"]["files"].items()) timed.insert(file);
    std::set<std::string> expected_timed = options.files;
    expected_timed.erase("camera.json");
    EXPECT_EQ(timed, expected_timed) << list;
    // The shared cloud only when a file needs it.
    EXPECT_EQ(json["timing_ms"].contains("valid_points"),
              options.files.count("points.ply") + options.files.count("preview.png") > 0)
        << list;
  }
}

// On two threads the files are written concurrently (and the geometry's parallel loops run in
// parallel elsewhere): every byte must be what one thread writes.
TEST(PredictOutputs, ConcurrentWritingMatchesOneThread) {
  const data::synth::SynthSample synth = render("PINHOLE 64 48 52 52 32 24");
  Prediction p = prediction_from_geometry(synth.rays, synth.sample.distance, synth.sample.mask);
  p.fitted_camera = camera::parse_camera("PINHOLE 64 48 52 52 32 24");
  OutputOptions options;
  options.files = parse_output_list("all");
  options.camera_from_world = at::eye(4, at::kDouble);
  const fs::path root = fresh_dir("concurrent");
  for (const int threads : {1, 2}) {
    const test::ThreadCount count(threads);
    write_prediction_outputs((root / std::to_string(threads)).string(), synth.sample.image, p,
                             options);
  }
  const std::set<std::string> files = files_in(root / "1");
  ASSERT_EQ(files_in(root / "2"), files);
  ASSERT_EQ(files.size(), options.files.size() + 2);  // + points_world.ply, cameras.txt
  for (const std::string& file : files) {
    if (file == "camera.json") continue;
    EXPECT_EQ(io::read_file((root / "2" / file).string()),
              io::read_file((root / "1" / file).string()))
        << file;
  }
  auto one = camera_json(root / "1"), two = camera_json(root / "2");
  EXPECT_EQ(two["timing_ms"]["files"].size(), one["timing_ms"]["files"].size());
  one.erase("timing_ms");
  two.erase("timing_ms");
  EXPECT_EQ(two, one);
}

// Files over the writer's 4 MiB buffer go out with O_DIRECT by default (io/atomic_file.h):
// byte for byte what the page cache writes.
TEST(PredictOutputs, DirectWritesMatchCachedWrites) {
  const data::synth::SynthSample synth = render("PINHOLE 1024 768 800 800 512 384");
  Prediction p = prediction_from_geometry(synth.rays, synth.sample.distance, synth.sample.mask);
  OutputOptions options;
  options.files = parse_output_list("all");
  const fs::path root = fresh_dir("direct");
  for (const auto mode : {io::LargeFileWrites::direct, io::LargeFileWrites::page_cache}) {
    io::set_large_file_writes(mode);
    write_prediction_outputs(
        (root / (mode == io::LargeFileWrites::direct ? "direct" : "cached")).string(),
        synth.sample.image, p, options);
  }
  io::set_large_file_writes(io::LargeFileWrites::direct);
  const std::set<std::string> files = files_in(root / "direct");
  ASSERT_EQ(files_in(root / "cached"), files);
  EXPECT_GT(fs::file_size(root / "direct" / "points.npy"), std::uintmax_t{4} << 20);
  for (const std::string& file : files) {
    if (file == "camera.json") continue;
    EXPECT_TRUE(io::read_file((root / "direct" / file).string()) ==
                io::read_file((root / "cached" / file).string()))
        << file;
  }
}

// A file that fails while others are being written: its error comes out, and nothing of the
// folder is left (a non-finite point inside the mask cannot go into mesh.glb).
TEST(PredictOutputs, AFailingFileLeavesNoFolderOnTwoThreads) {
  const test::ThreadCount count(2);
  Prediction p = step_prediction();
  p.points[2][5][0] = std::numeric_limits<float>::infinity();
  OutputOptions options;
  options.files = parse_output_list("all");
  const fs::path parent = fresh_dir("failing");
  try {
    write_prediction_outputs((parent / "sample").string(), at::rand({6, 8, 3}), p, options);
    FAIL() << "expected the mesh to fail";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "glb: points must be finite");
  }
  EXPECT_TRUE(fs::is_empty(parent));
}

// The PNGs' scales, and the valid pixels each cannot hold, counted in camera.json.
TEST(PredictOutputs, DepthAndDistancePngsStateTheirRange) {
  // Rays forward, forward, forward, backward, sideways and one invalid pixel.
  const at::Tensor rays = at::tensor({0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 0.f, 0.f, -1.f,
                                      1.f, 0.f, 0.f, 0.f, 0.f, 0.f})
                              .view({2, 3, 3});
  const at::Tensor distance = at::tensor({2.001f, 70.f, 300.f, 5.f, 3.f, 0.f}).view({2, 3});
  const at::Tensor mask = at::tensor({1, 1, 1, 1, 1, 0}).view({2, 3}).to(at::kBool);
  const Prediction p = prediction_from_geometry(rays, distance, mask);
  OutputOptions options;
  options.files = parse_output_list("depth");
  const fs::path folder = fresh_dir("png_range") / "sample";
  write_prediction_outputs(folder.string(), at::zeros({2, 3, 3}), p, options);

  // depth.png: millimetres; 70 m and 300 m beyond 65.535 m, two pixels at z <= 0.
  EXPECT_TRUE(at::equal(io::read_image_values((folder / "depth.png").string()),
                        at::tensor({2001.f, 0.f, 0.f, 0.f, 0.f, 0.f}).view({2, 3})));
  // distance.png: 1/256 m; only 300 m is beyond 255.996 m.
  EXPECT_TRUE(at::equal(io::read_image_values((folder / "distance.png").string()),
                        at::tensor({512.f, 17920.f, 0.f, 1280.f, 768.f, 0.f}).view({2, 3})));
  const auto json = camera_json(folder);
  EXPECT_EQ(json["depth_png"]["scale_m_per_unit"].get<double>(), 0.001);
  EXPECT_DOUBLE_EQ(json["depth_png"]["max_m"].get<double>(), 65.535);
  EXPECT_EQ(json["depth_png"]["behind_camera_pixels"].get<int64_t>(), 2);
  EXPECT_EQ(json["depth_png"]["out_of_range_pixels"].get<int64_t>(), 2);
  EXPECT_EQ(json["distance_png"]["scale_m_per_unit"].get<double>(), 1.0 / 256);
  EXPECT_EQ(json["distance_png"]["max_m"].get<double>(), 65535.0 / 256);
  EXPECT_EQ(json["distance_png"]["out_of_range_pixels"].get<int64_t>(), 1);
}

TEST(PredictOutputs, EdgeFilterRemovesTheStepAndSaysSo) {
  const Prediction unfiltered = step_prediction();
  Prediction p = unfiltered;
  remove_depth_edges(p, 0);  // off
  EXPECT_TRUE(at::equal(p.mask, unfiltered.mask));
  EXPECT_EQ(p.edge_pixels_removed, 0);
  remove_depth_edges(p, kDefaultEdgeRtol);
  // Image columns 3 and 4 (both sides of the step) leave the mask, with their geometry.
  at::Tensor expected = at::ones({6, 8}, at::kBool);
  expected.slice(1, 3, 5).fill_(false);
  EXPECT_TRUE(at::equal(p.mask, expected));
  EXPECT_EQ(p.edge_pixels_removed, 12);
  EXPECT_EQ(p.edge_rtol, kDefaultEdgeRtol);
  EXPECT_EQ(p.points.masked_select(~expected.unsqueeze(-1)).abs().max().item<float>(), 0);
  EXPECT_EQ(p.distance.masked_select(~expected).abs().max().item<float>(), 0);
  EXPECT_EQ(p.depth.masked_select(~expected).abs().max().item<float>(), 0);
  EXPECT_TRUE(
      at::equal(p.distance.masked_select(expected), unfiltered.distance.masked_select(expected)));

  // camera.json reports it; the mesh has 2 triangles per cell of columns 0..2 and 5..7.
  OutputOptions options;
  options.files = parse_output_list("mesh");
  const fs::path folder = fresh_dir("edges") / "sample";
  write_prediction_outputs(folder.string(), at::rand({6, 8, 3}), p, options);
  auto json = camera_json(folder);
  EXPECT_EQ(json["edge_filter"]["rtol"].get<double>(), kDefaultEdgeRtol);
  EXPECT_EQ(json["edge_filter"]["removed_pixels"].get<int64_t>(), 12);
  EXPECT_EQ(json["valid_pixels"].get<int64_t>(), 48 - 12);
  EXPECT_EQ(json["mesh"]["triangles"].get<int64_t>(), 2 * 5 * (2 + 2));
  EXPECT_EQ(json["mesh"]["vertices"].get<int64_t>(), 6 * (3 + 3));
  const std::string glb = io::read_file((folder / "mesh.glb").string());
  const auto gltf = nlohmann::json::parse(glb.substr(20, u32_at(glb, 12)));
  EXPECT_EQ(gltf["accessors"][2]["count"].get<int64_t>(), 3 * 2 * 5 * (2 + 2));

  // Unfiltered, the mesh skips the step's cells itself, unless told not to (rtol 0).
  write_prediction_outputs(folder.string(), at::rand({6, 8, 3}), unfiltered, options);
  json = camera_json(folder);
  EXPECT_EQ(json["edge_filter"]["removed_pixels"].get<int64_t>(), 0);
  EXPECT_EQ(json["mesh"]["triangles"].get<int64_t>(), 2 * 5 * (2 + 2));
  options.mesh_edge_rtol = 0;
  write_prediction_outputs(folder.string(), at::rand({6, 8, 3}), unfiltered, options);
  EXPECT_EQ(camera_json(folder)["mesh"]["triangles"].get<int64_t>(), 2 * 5 * 7);
}

TEST(PredictOutputs, NormalsOfATiltedPlane) {
  // The plane n · P = 4 with n = (0, 0.6, 0.8) seen through a pinhole: normals.npy is -n.
  const camera::Rays rays = camera::parse_camera("PINHOLE 16 12 14 14 8 6").ray_map();
  const at::Tensor distance = 4.0f / (rays.rays * at::tensor({0.f, 0.6f, 0.8f})).sum(-1);
  const Prediction p = prediction_from_geometry(rays.rays, distance, rays.valid);
  OutputOptions options;
  options.files = parse_output_list("normals.npy");
  const fs::path folder = fresh_dir("normals") / "sample";
  write_prediction_outputs(folder.string(), at::zeros({12, 16, 3}), p, options);
  const at::Tensor normals = io::read_npy((folder / "normals.npy").string());
  ASSERT_EQ(normals.sizes(), (at::IntArrayRef{12, 16, 3}));
  EXPECT_LT((normals - at::tensor({0.f, -0.6f, -0.8f})).abs().max().item<float>(), 1e-5);
}

}  // namespace
}  // namespace omnipoint::predict
