// predict::PredictJob, the library's "predict a folder" (what `omnipoint predict` runs): a
// folder of images into one output folder each, the resize to max_size, sparse-depth files
// matched to images, a failing image counted and skipped, COLMAP views fused into fused.ply,
// the options' checks, and the observer's reports in order.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/colmap.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/predict_job.h"
#include "predict/tiny_model.h"
#include "support/cli_run.h"
#include "support/colmap_writer.h"
#include "support/scratch_dir.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

constexpr char kCamera[] = "PINHOLE 40 30 35 35 20 15";

// Every report as one line, in the order it came.
struct Recorder : PredictJobObserver {
  std::vector<std::string> events;
  std::vector<PredictedImage> written;
  void start(const ImageList& images) override {
    events.push_back("start " + std::to_string(images.images.size()));
  }
  void note(const std::string& text) override { events.push_back("note " + text); }
  void image_started(size_t index, const ImageEntry& image) override {
    events.push_back("image " + std::to_string(index) + " " + image.relative.generic_string());
  }
  void warning(const ImageEntry& image, const std::string& text) override {
    events.push_back("warning " + image.relative.generic_string() + ": " + text);
  }
  void image_written(const ImageEntry& image, const PredictedImage& predicted) override {
    events.push_back("written " + image.relative.generic_string());
    written.push_back(predicted);
  }
  void image_failed(const ImageEntry& image, const std::string& error) override {
    events.push_back("failed " + image.relative.generic_string() + ": " + error);
  }
  void image_done(size_t index) override { events.push_back("done " + std::to_string(index)); }
  void finished(const PredictJobSummary& summary) override {
    events.push_back("finished " + std::to_string(summary.written) + " " +
                     std::to_string(summary.failed) + " " + std::to_string(summary.warnings));
  }
  int count(const std::string& start) const {
    int n = 0;
    for (const std::string& event : events) n += event.rfind(start, 0) == 0 ? 1 : 0;
    return n;
  }
};

class PredictJobTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_process_dir(
        "omnipoint_predict_job_" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  }
  void TearDown() override { fs::remove_all(dir_); }
  PredictJobOptions options(const std::vector<std::string>& inputs) const {
    PredictJobOptions job;
    job.inputs = inputs;
    job.model_path = tiny_model_path();
    job.num_tokens = 12;
    job.output_dir = (dir_ / "out").string();
    return job;
  }
  void image(const fs::path& relative, int64_t width = 40, int64_t height = 30) const {
    fs::create_directories((dir_ / relative).parent_path());
    io::write_image_png((dir_ / relative).string(), at::rand({height, width, 3}));
  }
  fs::path dir_;
};

TEST_F(PredictJobTest, AFolderIsPredictedImageByImageWithItsReportsInOrder) {
  image("shots/a.png");
  image("shots/day/b.png");
  std::ofstream(dir_ / "shots" / "notes.txt") << "not an image";
  // What a run killed with SIGKILL left: a staging folder no live process holds.
  fs::create_directories(dir_ / "out" / ".a.partial-Ab12cd");
  Recorder recorder;
  PredictJobOptions job = options({(dir_ / "shots").string()});
  job.camera = kCamera;
  const PredictJobSummary summary = PredictJob(job, &recorder).Run();
  EXPECT_EQ(summary.images, 2);
  EXPECT_EQ(summary.written, 2);
  EXPECT_EQ(summary.failed, 0);
  EXPECT_EQ(summary.warnings, 0);
  EXPECT_TRUE(summary.fused_cloud.empty());
  const std::vector<std::string> expected = {
      "start 2",
      "note 1 file(s) in the input folders are not images and were skipped",
      "image 0 a.png",
      "written a.png",
      "done 0",
      "image 1 day/b.png",
      "written day/b.png",
      "done 1",
      "finished 2 0 0"};
  EXPECT_EQ(recorder.events, expected);
  for (const char* folder : {"a", "day/b"})
    EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / folder / "camera.json")) << folder;
  EXPECT_FALSE(fs::exists(dir_ / "out" / ".a.partial-Ab12cd"));
  ASSERT_EQ(recorder.written.size(), 2u);
  const PredictedImage& a = recorder.written[0];
  EXPECT_EQ(a.folder, (dir_ / "out" / "a").string());
  EXPECT_EQ(a.size.width, 40);
  EXPECT_EQ(a.original_size.width, 40);
  EXPECT_EQ(a.prediction.points.size(1), 40);
  EXPECT_EQ(describe({dir_ / "shots" / "a.png", "a.png", "a"}, a)
                .rfind((dir_ / "shots" / "a.png").string() + " -> " + a.folder + " (", 0),
            0u);
}

// max_size is the library's: the image, its sparse depth map and the given camera are brought
// to the network's size together.
TEST_F(PredictJobTest, MaxSizeResizesTheImageTheSparseDepthAndTheCamera) {
  image("large.png", 80, 60);
  io::write_npy((dir_ / "large.npy").string(), at::full({60, 80}, 2.0, at::kFloat));
  Recorder recorder;
  PredictJobOptions job = options({(dir_ / "large.png").string()});
  job.camera = "PINHOLE 80 60 70 70 40 30";
  job.sparse_depth = (dir_ / "large.npy").string();
  job.max_size = 40;
  ASSERT_EQ(PredictJob(job, &recorder).Run().written, 1);
  ASSERT_EQ(recorder.written.size(), 1u);
  const PredictedImage& large = recorder.written[0];
  EXPECT_EQ(large.original_size.width, 80);
  EXPECT_EQ(large.original_size.height, 60);
  EXPECT_EQ(large.size.width, 40);
  EXPECT_EQ(large.size.height, 30);
  // Every pixel of the 40x30 map has a sample: the map was resized with the image.
  EXPECT_GT(large.prediction.sparse_samples, 0);
  EXPECT_LE(large.prediction.sparse_samples, 40 * 30);
  const std::string line = describe({dir_ / "large.png", "large.png", "large"}, large);
  EXPECT_NE(line.find(" at 40x30, "), std::string::npos) << line;
  EXPECT_NE(line.find(" sparse samples"), std::string::npos) << line;
  const at::Tensor mask = io::read_image_values((dir_ / "out" / "large" / "mask.png").string());
  EXPECT_EQ(mask.sizes(), (at::IntArrayRef{30, 40}));
  const at::Tensor rays = io::read_npy((dir_ / "out" / "large" / "rays.npy").string());
  EXPECT_TRUE(at::allclose(rays, camera::parse_camera(kCamera).ray_map().rays, 1e-5, 1e-6));
}

TEST_F(PredictJobTest, SparseDepthFilesAreMatchedByPathThenByName) {
  image("frames/a.png");
  image("frames/left/b.png");
  image("frames/c.png");
  fs::create_directories(dir_ / "depth" / "left");
  io::write_npy((dir_ / "depth" / "a.npy").string(), at::full({30, 40}, 3.0, at::kFloat));
  // b by its path below the folder, which wins over a file of its bare name.
  io::write_npy((dir_ / "depth" / "left" / "b.npy").string(), at::full({30, 40}, 3.0, at::kFloat));
  io::write_npy((dir_ / "depth" / "b.npy").string(), at::ones({2, 2}, at::kFloat));
  const ImageList list = list_images({(dir_ / "frames").string()});
  ASSERT_EQ(list.images.size(), 3u);
  const std::vector<std::string>& extensions = sparse_depth_extensions();
  EXPECT_EQ(per_image_file(dir_ / "depth", list.images[0], extensions), dir_ / "depth" / "a.npy");
  EXPECT_EQ(per_image_file(dir_ / "depth", list.images[2], extensions),
            dir_ / "depth" / "left" / "b.npy");
  EXPECT_EQ(per_image_file(dir_ / "depth", list.images[1], extensions), std::nullopt);
  fs::remove(dir_ / "depth" / "left" / "b.npy");
  EXPECT_EQ(per_image_file(dir_ / "depth", list.images[2], extensions), dir_ / "depth" / "b.npy");
  io::write_npy((dir_ / "depth" / "left" / "b.npy").string(), at::full({30, 40}, 3.0, at::kFloat));

  Recorder recorder;
  PredictJobOptions job = options({(dir_ / "frames").string()});
  job.camera = kCamera;
  job.sparse_depth = (dir_ / "depth").string();
  const PredictJobSummary summary = PredictJob(job, &recorder).Run();
  EXPECT_EQ(summary.written, 3);
  EXPECT_EQ(summary.failed, 0);
  EXPECT_EQ(recorder.count("warning c.png: no sparse depth file for it in " + job.sparse_depth +
                           " (looked for its name with 6 extensions): predicted without"),
            1)
      << ::testing::PrintToString(recorder.events);
  EXPECT_EQ(summary.warnings, recorder.count("warning "));
  ASSERT_EQ(recorder.written.size(), 3u);
  EXPECT_GT(recorder.written[0].prediction.sparse_samples, 0);  // a
  EXPECT_EQ(recorder.written[1].prediction.sparse_samples, 0);  // c
  EXPECT_GT(recorder.written[2].prediction.sparse_samples, 0);  // left/b
}

TEST_F(PredictJobTest, AFailingImageIsCountedAndSkipped) {
  std::ofstream(dir_ / "corrupt.png") << "not a png";
  image("good.png");
  io::write_npy((dir_ / "small.npy").string(), at::ones({10, 10}));
  // The corrupt image first: with a camera it is decoded ahead of its turn (for the camera's
  // size), and still reported once, in its turn.
  for (const bool camera : {false, true}) {
    SCOPED_TRACE(camera ? "with a camera" : "without");
    fs::remove_all(dir_ / "out");
    Recorder recorder;
    PredictJobOptions job =
        options({(dir_ / "corrupt.png").string(), (dir_ / "good.png").string()});
    if (camera) job.camera = kCamera;
    const PredictJobSummary summary = PredictJob(job, &recorder).Run();
    EXPECT_EQ(summary.images, 2);
    EXPECT_EQ(summary.written, 1);
    EXPECT_EQ(summary.failed, 1);
    ASSERT_GE(recorder.events.size(), 4u);
    EXPECT_EQ(recorder.events[1], "image 0 corrupt.png");
    EXPECT_EQ(recorder.events[2].rfind("failed corrupt.png: ", 0), 0u) << recorder.events[2];
    EXPECT_NE(recorder.events[2].find("corrupt.png"), std::string::npos);
    EXPECT_EQ(recorder.events[3], "done 0");
    EXPECT_EQ(recorder.count("failed "), 1);
    EXPECT_FALSE(fs::exists(dir_ / "out" / "corrupt"));
    EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / "good" / "camera.json"));
  }
  // A bad sparse depth file fails its image the same way.
  Recorder recorder;
  PredictJobOptions job = options({(dir_ / "good.png").string()});
  job.output_dir = (dir_ / "bad_sparse").string();
  job.camera = kCamera;
  job.sparse_depth = (dir_ / "small.npy").string();
  const PredictJobSummary summary = PredictJob(job, &recorder).Run();
  EXPECT_EQ(summary.failed, 1);
  EXPECT_EQ(recorder.count("failed good.png: sparse depth"), 1)
      << ::testing::PrintToString(recorder.events);
  EXPECT_FALSE(fs::exists(dir_ / "bad_sparse" / "good"));
}

// Each option mistake is one line, thrown before anything is read or written.
TEST_F(PredictJobTest, CheckRejectsInvalidAndConflictingOptions) {
  image("good.png");
  const PredictJobOptions valid = options({(dir_ / "good.png").string()});
  EXPECT_NO_THROW(valid.Check());
  const auto rejected = [&](const auto& change, const std::string& message) {
    PredictJobOptions job = valid;
    change(job);
    try {
      job.Check();
      ADD_FAILURE() << "no error; expected " << message;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
    EXPECT_THROW(PredictJob(job).Run(), std::invalid_argument) << message;
  };
  rejected([](PredictJobOptions& j) { j.inputs.clear(); }, "no images given");
  rejected(
      [](PredictJobOptions& j) {
        j.camera = kCamera;
        j.fov_deg = 60;
      },
      "--camera and --fov: give one of them");
  rejected(
      [](PredictJobOptions& j) {
        j.colmap = "sparse";
        j.sparse_depth = "depth";
      },
      "--colmap brings each image's camera and sparse depth");
  rejected([](PredictJobOptions& j) { j.fov_deg = 180; }, "--fov 180");
  rejected([](PredictJobOptions& j) { j.depth_png_units_per_metre = 0; }, "--depth-scale 0");
  rejected([](PredictJobOptions& j) { j.lidar_floats_per_point = 2; }, "--lidar-format 2");
  rejected([](PredictJobOptions& j) { j.model_path.clear(); }, "--model: no model given");
  rejected([](PredictJobOptions& j) { j.max_size = -1; }, "--max-size -1");
  rejected([](PredictJobOptions& j) { j.num_tokens = -5; }, "--num-tokens -5");
  rejected([](PredictJobOptions& j) { j.edge_rtol = -0.1; }, "--edge-threshold -0.1");
  rejected([](PredictJobOptions& j) { j.output_dir.clear(); }, "--out: no output folder");
  rejected([](PredictJobOptions& j) { j.output_files.insert("points.xyz"); },
           "unknown file \"points.xyz\"");
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  // Errors of the whole job (here one sparse depth file for two images, and a missing input)
  // are thrown by Run() before any image.
  PredictJobOptions two = options({(dir_ / "good.png").string(), (dir_ / "good.png").string()});
  two.sparse_depth = (dir_ / "good.png").string();
  EXPECT_THROW(PredictJob(two).Run(), std::invalid_argument);
  EXPECT_THROW(PredictJob(options({(dir_ / "missing.png").string()})).Run(), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// Two registered views and one that is not: the views get their COLMAP camera, pose and sparse
// depth, and fused.ply holds the world-frame points of both, written once at the end.
TEST_F(PredictJobTest, ColmapViewsAreFusedInTheReconstructionsWorldFrame) {
  test::ColmapScene scene;
  scene.cameras.push_back({1, "PINHOLE", 40, 30, {35, 35, 20, 15}});
  const std::array<double, 3> shift{-0.5, 0.2, 0.0};  // camera-from-world translation of view 2
  for (int k = 0; k < 2; ++k) {
    io::ColmapImage view;
    view.id = k + 1;
    view.camera_id = 1;
    view.name = "view_" + std::to_string(k) + ".png";
    if (k == 1) view.tvec = shift;
    scene.images.push_back(view);
    image(fs::path("images") / view.name);
  }
  image("images/unregistered.png");
  // World points 3 m in front of view 1, each observed by both views where it projects.
  int64_t id = 1;
  for (int u = 2; u < 40; u += 4)
    for (int v = 2; v < 30; v += 4, ++id) {
      const double z = 3.0, x = (u - 20) * z / 35, y = (v - 15) * z / 35;
      io::ColmapPoint point;
      point.xyz = {x, y, z};
      scene.points.emplace(id, point);
      for (int k = 0; k < 2; ++k) {
        const double xc = x + (k == 1 ? shift[0] : 0), yc = y + (k == 1 ? shift[1] : 0);
        const double column = 35 * xc / z + 20, row = 35 * yc / z + 15;
        if (column < 0 || column >= 40 || row < 0 || row >= 30) continue;
        scene.images[k].points2d.push_back({column, row});
        scene.images[k].point3d_ids.push_back(id);
      }
    }
  test::write_colmap_text(dir_ / "sparse", scene);

  Recorder recorder;
  PredictJobOptions job = options({(dir_ / "images").string()});
  job.colmap = (dir_ / "sparse").string();
  const PredictJobSummary summary = PredictJob(job, &recorder).Run();
  EXPECT_EQ(summary.written, 3);
  EXPECT_EQ(recorder.count("note COLMAP's scale is arbitrary"), 1);
  EXPECT_EQ(recorder.count("warning unregistered.png: not an image of the COLMAP reconstruction"),
            1);
  EXPECT_EQ(summary.fused_cloud, (dir_ / "out" / "fused.ply").string());
  EXPECT_EQ(summary.fused_images, 2);
  int64_t fused_expected = 0;
  for (const char* name : {"view_0", "view_1"}) {
    SCOPED_TRACE(name);
    const io::PlyPoints camera_frame = io::read_ply((dir_ / "out" / name / "points.ply").string());
    const io::PlyPoints world = io::read_ply((dir_ / "out" / name / "points_world.ply").string());
    ASSERT_EQ(world.points.size(0), camera_frame.points.size(0));
    fused_expected += world.points.size(0);
    // X_world = X_camera - t (the rotation is the identity).
    const at::Tensor t =
        std::string(name) == "view_1" ? at::tensor({-0.5f, 0.2f, 0.0f}) : at::zeros({3});
    EXPECT_TRUE(at::allclose(world.points, camera_frame.points - t, 1e-4, 1e-5));
  }
  EXPECT_FALSE(fs::exists(dir_ / "out" / "unregistered" / "points_world.ply"));
  for (const PredictedImage& predicted : recorder.written)
    EXPECT_EQ(predicted.prediction.sparse_samples > 0,
              predicted.folder.find("unregistered") == std::string::npos)
        << predicted.folder;
  EXPECT_GT(fused_expected, 0);
  const io::PlyPoints fused = io::read_ply(summary.fused_cloud);
  EXPECT_EQ(fused.points.size(0), fused_expected);
  EXPECT_EQ(summary.fused_points, fused_expected);
  EXPECT_EQ(summary.warnings, recorder.count("warning "));
  EXPECT_EQ(recorder.events.back(), "finished 3 0 " + std::to_string(summary.warnings));
}

// The tool runs this job: the same inputs give the same files.
TEST_F(PredictJobTest, TheToolWritesWhatTheJobWrites) {
  image("good.png");
  PredictJobOptions job = options({(dir_ / "good.png").string()});
  job.camera = kCamera;
  ASSERT_EQ(PredictJob(job).Run().written, 1);
  const test::CliRun run = test::run_omnipoint(
      "predict " + (dir_ / "good.png").string() + " --camera '" + kCamera + "' --model " +
          tiny_model_path() + " --num-tokens 12 --precision fp32 --out " + (dir_ / "tool").string(),
      dir_ / "run");
  ASSERT_EQ(run.status, 0) << run.err;
  for (const char* file : {"points.npy", "rays.npy", "mask.png", "depth.png", "points.ply"})
    EXPECT_EQ(test::slurp(dir_ / "tool" / "good" / file), test::slurp(dir_ / "out" / "good" / file))
        << file;
}

}  // namespace
}  // namespace omnipoint::predict
