// Sparse-depth inputs (every file format gives the same map, LiDAR points land on the right
// pixels) and the predictor on a tiny random model (thread safety, batches, alignment).
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/geometry/grid_surface.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/io/point_cloud.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/predictor.h"
#include "predict/tiny_model.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("omnipoint_predictor_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void write_bytes(const fs::path& path, const void* data, size_t size) {
  io::write_file_atomically(
      path.string(), [&](std::ostream& out) { out.write(static_cast<const char*>(data), size); });
}

// The same scene as every format: a sparse set of pixels on a smooth surface with planar depth
// in whole millimetres (so the 16-bit PNG is exact), and the LiDAR points at those pixels'
// centres (a surface: a point cloud is read as a sensor's sweep, whose returns behind nearer
// ones around them are taken as hidden from the camera).
TEST(SparseDepthFiles, EveryFormatGivesTheSameMap) {
  const camera::Camera camera = camera::parse_camera("PINHOLE 40 30 35 33 20.5 14.5");
  const at::Tensor rays = camera.ray_map().rays;
  at::Tensor depth_mm = at::zeros({30, 40}, at::kInt);
  const at::Tensor picked = at::rand({30, 40}, at::make_generator<at::CPUGeneratorImpl>(4)) < 0.1;
  const at::Tensor column = at::arange(40, at::kInt).view({1, 40}),
                   row = at::arange(30, at::kInt).view({30, 1});
  depth_mm.index_put_({picked}, (1500 + 40 * column + 25 * row).expand({30, 40}).index({picked}));
  const at::Tensor depth = depth_mm.to(at::kDouble) / 1000.0;

  const fs::path dir = fresh_dir("formats");
  io::write_image_png((dir / "depth.png").string(), depth_mm);
  io::write_npy((dir / "depth.npy").string(), depth.to(at::kFloat));
  // Points in the camera frame (z = depth) at the pixel centres, then in a LiDAR frame moved by T.
  const at::Tensor camera_points =
      (rays.to(at::kDouble) * (depth / rays.select(-1, 2).to(at::kDouble)).unsqueeze(-1))
          .index({picked});
  io::write_ply((dir / "cloud.ply").string(), camera_points);
  const at::Tensor lidar_points =
      camera_points - at::tensor({0.5, -0.25, 1.0}, at::kDouble);  // camera = lidar + t
  std::ofstream((dir / "lidar_to_camera.txt").string())
      << "1 0 0 0.5\n0 1 0 -0.25\n0 0 1 1.0\n0 0 0 1\n";
  const at::Tensor records =
      at::cat({lidar_points.to(at::kFloat), at::ones({lidar_points.size(0), 1})}, 1).contiguous();
  write_bytes(dir / "scan.bin", records.data_ptr<float>(), records.numel() * sizeof(float));
  // nuScenes: x y z intensity ring.
  const at::Tensor nuscenes =
      at::cat({records, at::full({lidar_points.size(0), 1}, 7.0f)}, 1).contiguous();
  write_bytes(dir / "nuscenes.bin", nuscenes.data_ptr<float>(), nuscenes.numel() * sizeof(float));
  // KITTI depth-completion PNG: metres x 256 (quantised, so compared at its own precision below).
  io::write_image_png((dir / "kitti.png").string(), (depth * 256).round().to(at::kInt));
  // An ASCII PCD (PCL's v0.7 header) in the camera frame.
  {
    std::ofstream pcd((dir / "cloud.pcd").string());
    pcd << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\n"
        << "SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " << camera_points.size(0)
        << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << camera_points.size(0)
        << "\nDATA ascii\n";
    pcd.precision(9);
    const auto p = camera_points.accessor<double, 2>();
    for (int64_t i = 0; i < p.size(0); ++i)
      pcd << p[i][0] << " " << p[i][1] << " " << p[i][2] << "\n";
  }

  const at::Tensor expected =
      (depth / rays.select(-1, 2).to(at::kDouble)).where(picked, at::zeros_like(depth));
  struct Case {
    std::string file;
    SparseDepthFileOptions options;
    double tolerance = 1e-5;
  };
  const at::Tensor transform = io::read_rigid_transform((dir / "lidar_to_camera.txt").string());
  for (const Case& c : std::vector<Case>{{"depth.png", {}},
                                         {"kitti.png", {256.0, 4, {}}, 0.7 / 256},
                                         {"depth.npy", {}},
                                         {"cloud.ply", {}},
                                         {"cloud.pcd", {}},
                                         {"scan.bin", {1000.0, 4, transform}},
                                         {"nuscenes.bin", {1000.0, 5, transform}}}) {
    const SparseDepthInput input = read_sparse_depth((dir / c.file).string(), c.options);
    const at::Tensor map = sparse_distance_map(input, 40, 30, rays, &camera);
    EXPECT_TRUE(at::equal(map > 0, picked)) << c.file;
    EXPECT_TRUE(at::allclose(map.to(at::kDouble), expected, 1e-5, c.tolerance)) << c.file;
  }
  // The KITTI PNG read as millimetres (the default) is 256/1000 of the truth: the mistake the
  // option exists for.
  const at::Tensor as_mm =
      sparse_distance_map(read_sparse_depth((dir / "kitti.png").string()), 40, 30, rays, &camera);
  EXPECT_NEAR((as_mm.sum() / expected.sum()).item<double>(), 0.256, 1e-3);
}

TEST(SparseDepthFiles, LidarPointLandsOnItsPixel) {
  const camera::Camera camera = camera::parse_camera("PINHOLE 40 30 35 35 20 15");
  // A point 5 m ahead of the camera, 1 m right: pixel x = 20 + 35·0.2 = 27 -> column 27,
  // row 15 (the point sits on a pixel corner, so shift it by a quarter pixel into (27, 15)).
  SparseDepthInput input;
  const double x = (27.25 - 20) / 35 * 5, y = (15.25 - 15) / 35 * 5;
  input.lidar_points = at::tensor({x, y, 5.0 - 2.0}, at::kDouble).view({1, 3});
  input.camera_from_lidar = at::eye(4, at::kDouble);
  input.camera_from_lidar[2][3] = 2.0;  // the LiDAR sits 2 m behind the camera
  const at::Tensor map = sparse_distance_map(input, 40, 30, {}, &camera);
  EXPECT_EQ(map.nonzero().size(0), 1);
  EXPECT_NEAR(map[15][27].item<double>(), std::sqrt(x * x + y * y + 25.0), 1e-5);
}

TEST(SparseDepthFiles, BadFilesNameThemselves) {
  const fs::path dir = fresh_dir("bad");
  std::ofstream((dir / "bad.ply").string())
      << "ply\nformat ascii 1.0\nelement vertex 2\nend_header\n1 2\n";
  std::ofstream((dir / "bad.bin").string()) << "12345";
  std::ofstream((dir / "bad.txt").string()) << "1 2 3";
  for (const std::string name : {"bad.ply", "bad.bin", "bad.txt", "missing.npy"}) {
    try {
      read_sparse_depth((dir / name).string());
      ADD_FAILURE() << name;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
  SparseDepthInput wrong_size;
  wrong_size.depth_map = at::ones({10, 10});
  EXPECT_THROW(sparse_distance_map(wrong_size, 40, 30, at::zeros({30, 40, 3}), nullptr),
               std::invalid_argument);
}

TEST(Predictor, ConcurrentCallsMatchSequentialOnes) {
  const Model model = Model::load(tiny_model_path());
  EXPECT_EQ(model.format(), "omnipoint");
  std::vector<at::Tensor> images;
  for (int i = 0; i < 4; ++i)
    images.push_back(at::rand({30, 40, 3}, at::make_generator<at::CPUGeneratorImpl>(i)));
  PredictOptions options;
  options.num_tokens = 12;
  options.camera = camera::parse_camera("PINHOLE 40 30 35 35 20 15");
  std::vector<Prediction> sequential;
  for (const at::Tensor& image : images) sequential.push_back(model.predict(image, options));
  std::vector<Prediction> concurrent(images.size());
  std::vector<std::thread> threads;
  for (size_t i = 0; i < images.size(); ++i)
    threads.emplace_back([&, i] { concurrent[i] = model.predict(images[i], options); });
  for (std::thread& thread : threads) thread.join();
  for (size_t i = 0; i < images.size(); ++i) {
    EXPECT_TRUE(at::allclose(concurrent[i].points, sequential[i].points, 1e-5, 1e-6)) << i;
    EXPECT_TRUE(at::equal(concurrent[i].mask, sequential[i].mask)) << i;
    ASSERT_TRUE(concurrent[i].fitted_camera.has_value() || !concurrent[i].fit_error.empty());
  }
  // A batch gives the per-image results.
  const std::vector<Prediction> batch = model.predict_batch(at::stack(images), options);
  ASSERT_EQ(batch.size(), images.size());
  for (size_t i = 0; i < images.size(); ++i)
    EXPECT_TRUE(at::allclose(batch[i].distance, sequential[i].distance, 1e-4, 1e-5)) << i;
}

// The flying-pixel filter on the network's output: exactly geometry::depth_edge_mask of the
// unfiltered prediction's distance leaves the mask (and its geometry), counted; 0 is off.
TEST(Predictor, EdgeFilterTakesDepthEdgesOutOfTheMask) {
  const Model model = Model::load(tiny_model_path());
  const at::Tensor image = at::rand({30, 40, 3}, at::make_generator<at::CPUGeneratorImpl>(7));
  PredictOptions options;
  options.num_tokens = 12;
  options.camera = camera::parse_camera("PINHOLE 40 30 35 35 20 15");
  options.edge_rtol = 0;
  const Prediction off = model.predict(image, options);
  EXPECT_EQ(off.edge_rtol, 0);
  EXPECT_EQ(off.edge_pixels_removed, 0);
  EXPECT_EQ(PredictOptions{}.edge_rtol, kDefaultEdgeRtol);
  for (const double rtol : {kDefaultEdgeRtol, 0.002}) {
    options.edge_rtol = rtol;
    const Prediction p = model.predict(image, options);
    const at::Tensor edges = geometry::depth_edge_mask(off.distance, off.mask, rtol);
    EXPECT_EQ(p.edge_rtol, rtol);
    EXPECT_EQ(p.edge_pixels_removed, edges.sum().item<int64_t>()) << rtol;
    EXPECT_TRUE(at::equal(p.mask, off.mask & ~edges)) << rtol;
    EXPECT_FALSE(p.distance.masked_select(edges).ne(0).any().item<bool>()) << rtol;
    EXPECT_FALSE(p.points.masked_select(edges.unsqueeze(-1)).ne(0).any().item<bool>()) << rtol;
  }
  // The tight tolerance does find edges in a random network's output.
  EXPECT_GT(geometry::depth_edge_mask(off.distance, off.mask, 0.002).sum().item<int64_t>(), 0);
}

TEST(Predictor, SparseDepthAlignsTheMetricScale) {
  const Model model = Model::load(tiny_model_path());
  const at::Tensor image = at::rand({30, 40, 3}, at::make_generator<at::CPUGeneratorImpl>(9));
  PredictOptions options;
  options.num_tokens = 12;
  options.camera = camera::parse_camera("PINHOLE 40 30 35 35 20 15");
  options.fit_model = "";
  // Sparse radial distances exactly 3x an unconditioned prediction's: after the network sees
  // them its distances change, but the alignment still makes the samples' median ratio 1.
  const Prediction plain = model.predict(image, options);
  options.sparse_depth.depth_map =
      (plain.distance * 3).where(at::rand({30, 40}) < 0.2, at::zeros({30, 40}));
  options.sparse_depth.depth_is_planar = false;
  const Prediction aligned = model.predict(image, options);
  const at::Tensor used = (options.sparse_depth.depth_map > 0) & aligned.mask;
  EXPECT_EQ(aligned.sparse_samples, used.sum().item<int64_t>());
  const at::Tensor ratio =
      options.sparse_depth.depth_map.masked_select(used) / aligned.distance.masked_select(used);
  EXPECT_NEAR(ratio.median().item<double>(), 1.0, 0.05);
  EXPECT_TRUE(
      at::allclose(aligned.points, aligned.rays * aligned.distance.unsqueeze(-1), 1e-5, 1e-6));
}

TEST(Predictor, AGivenCameraIsUsedAsItIs) {
  const Model model = Model::load(tiny_model_path());
  const at::Tensor image = at::rand({32, 32, 3}, at::make_generator<at::CPUGeneratorImpl>(4));
  PredictOptions options;
  options.num_tokens = 12;
  options.fit_model = "";
  const Prediction free = model.predict(image, options);
  // A fisheye whose image circle leaves the corners outside its domain.
  options.camera = camera::parse_camera("OPENCV_FISHEYE 32 32 10 10 16 16 0 0 0 0");
  const camera::Rays truth = options.camera->ray_map(at::kFloat);
  const Prediction known = model.predict(image, options);
  EXPECT_TRUE(at::allclose(known.rays, truth.rays, 1e-6, 1e-6));
  EXPECT_FALSE(
      at::allclose(free.rays, truth.rays, 1e-2, 1e-2));  // the random network's own rays differ
  EXPECT_FALSE((known.mask & ~truth.valid).any().item<bool>());
  EXPECT_TRUE(at::allclose(known.points, known.rays * known.distance.unsqueeze(-1), 1e-5, 1e-6));
}

TEST(Predictor, LoadErrorsNameTheFile) {
  EXPECT_THROW(Model::load("/nonexistent/model.safetensors"), std::runtime_error);
  const fs::path dir = fresh_dir("load");
  io::write_safetensors((dir / "other.safetensors").string(), {{"x", at::ones({2})}},
                        {{"format", "other"}});
  try {
    Model::load((dir / "other.safetensors").string());
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("other.safetensors"), std::string::npos);
  }
}

}  // namespace
}  // namespace omnipoint::predict

namespace omnipoint::predict {
namespace {

// A MoGe-2 checkpoint runs through the same API as a pinhole model: its infer() points (the
// shared reference fixture, computed with MoGe's own code) come back as rays × distances.
TEST(Predictor, MoGe2CheckpointGivesItsInferPoints) {
  const std::string fixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a";
  const Model model = Model::load(fixture + "/model.safetensors");
  EXPECT_EQ(model.format(), "moge2");
  const at::Tensor image = io::read_npy(fixture + "/input.npy")[0].permute({1, 2, 0});
  PredictOptions options;
  options.num_tokens = 300;
  options.fit_model = "PINHOLE";
  options.edge_rtol = 0;  // MoGe's infer() mask: its script filters edges for the mesh only
  const Prediction p = model.predict(image, options);
  const at::Tensor expected_mask =
      io::read_npy(fixture + "/expected_infer_mask.npy")[0].to(at::kBool);
  const at::Tensor expected_points = io::read_npy(fixture + "/expected_infer_points.npy")[0];
  EXPECT_TRUE(at::equal(p.mask, expected_mask));
  const at::Tensor mask = p.mask.unsqueeze(-1).expand({-1, -1, 3});
  EXPECT_TRUE(
      at::allclose(p.points.masked_select(mask), expected_points.masked_select(mask), 1e-4, 1e-5));
  ASSERT_TRUE(p.fitted_camera.has_value()) << p.fit_error;
  EXPECT_EQ(p.fitted_camera->model_name(), "PINHOLE");
}

}  // namespace
}  // namespace omnipoint::predict

namespace omnipoint::predict {
namespace {

// A MoGe-2 checkpoint on a fisheye camera runs in A2P's multi-view mode and says so; the rays
// are the camera's.
TEST(Predictor, MoGe2OnAFisheyeUsesMultiViewMode) {
  const std::string fixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a";
  const Model model = Model::load(fixture + "/model.safetensors");
  PredictOptions options;
  options.num_tokens = 300;
  options.fit_model = "";
  options.camera = camera::parse_camera("OPENCV_FISHEYE 160 120 45 45 80 60 0 0 0 0");
  const Prediction p =
      model.predict(io::read_npy(fixture + "/input.npy")[0].permute({1, 2, 0}), options);
  ASSERT_EQ(p.notes.size(), 1u);
  EXPECT_NE(p.notes[0].find("multi-view"), std::string::npos) << p.notes[0];
  const camera::Rays rays = options.camera->ray_map();
  EXPECT_TRUE(at::allclose(p.rays.index({p.mask}), rays.rays.index({p.mask}), 1e-6, 1e-6));
  EXPECT_GT(p.mask.sum().item<int64_t>(), 0);
  EXPECT_TRUE(at::isfinite(p.points).all().item<bool>());
}

}  // namespace
}  // namespace omnipoint::predict
