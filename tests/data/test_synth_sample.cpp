// Synthetic samples: determinism, camera independence of scene and pose, the sample folder
// round trip, bad sample folders, crop/resize consistency and the CLI.
#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "support/cli_run.h"

namespace omnipoint::data {
namespace {
namespace fs = std::filesystem;
using synth::SceneKind;

fs::path fresh_dir(const std::string& name) {
  const auto dir = fs::temp_directory_path() / ("omnipoint_synth_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string file_bytes(const fs::path& p) {
  return io::read_file(p.string());
}

TEST(SynthSample, SameSeedGivesIdenticalBytesWhateverTheThreadCount) {
  const auto cam = camera::parse_camera("PINHOLE 64 48 52 52 32 24");
  const auto dir = fresh_dir("determinism");
  const int threads = at::get_num_threads();
  at::set_num_threads(1);
  synth::write_synth_sample((dir / "a").string(), synth::synthesize(SceneKind::kIndoor, 11, cam));
  at::set_num_threads(std::max(2, threads));
  synth::write_synth_sample((dir / "b").string(), synth::synthesize(SceneKind::kIndoor, 11, cam));
  at::set_num_threads(threads);
  for (const char* f : {"image.png", "distance.npy", "depth.npy", "rays.npy", "normals.npy",
                        "mask.png", "meta.json"})
    EXPECT_EQ(file_bytes(dir / "a" / f), file_bytes(dir / "b" / f)) << f;
  const auto other = synth::synthesize(SceneKind::kIndoor, 12, cam);
  const auto first = synth::synthesize(SceneKind::kIndoor, 11, cam);
  EXPECT_FALSE(at::equal(other.sample.distance, first.sample.distance));
}

TEST(SynthSample, SceneAndPoseDependOnTheSeedOnly) {
  for (auto kind : {SceneKind::kIndoor, SceneKind::kOutdoor, SceneKind::kObject}) {
    const auto pin = synth::synthesize(kind, 3, camera::parse_camera("PINHOLE 32 24 30 30 16 12"));
    const auto pano = synth::synthesize(kind, 3, camera::parse_camera("EQUIRECTANGULAR 64 32"));
    EXPECT_EQ(synth::scene_meta_json(pin.scene), synth::scene_meta_json(pano.scene));
    EXPECT_EQ(pin.scene.primitives.size(), pano.scene.primitives.size());
    // The same world ray through both cameras: the pinhole's optical axis is the
    // panorama's centre direction (azimuth 0, elevation 0) = pixel corner (32, 16), so
    // compare the mean of the four pixels around it with the pinhole's centre four.
    const auto centre = [](const at::Tensor& d, int64_t y, int64_t x) {
      return d.narrow(0, y - 1, 2).narrow(1, x - 1, 2).mean().item<double>();
    };
    const double a = centre(pin.sample.distance, 12, 16), b = centre(pano.sample.distance, 16, 32);
    if (a > 0 && b > 0 && a < 20) {
      EXPECT_NEAR(a, b, 0.15 * a) << synth::scene_kind_name(kind);
    }
  }
}

TEST(SynthSample, EveryKindProducesPlausibleGeometry) {
  const auto cam = camera::parse_camera("EQUIRECTANGULAR 64 32");
  for (auto kind : {SceneKind::kIndoor, SceneKind::kOutdoor, SceneKind::kObject})
    for (uint64_t seed : {0, 1, 2}) {
      const auto s = synth::synthesize(kind, seed, cam);
      validate_sample(s.sample, "synth");
      const double coverage = s.sample.mask.to(at::kFloat).mean().item<double>();
      const auto d = s.sample.distance.masked_select(s.sample.mask);
      if (kind == SceneKind::kOutdoor) {
        EXPECT_GT(coverage, 0.3);
        EXPECT_LT(coverage, 0.97);  // there is sky
      } else {
        EXPECT_GT(coverage, 0.9);                   // closed rooms, sky only through windows
        EXPECT_LT(d.median().item<double>(), 8.0);  // (windows may show a distant lawn)
      }
      EXPECT_GT(d.min().item<double>(), 0.05);
      const auto n = s.normals.index({s.sample.mask});
      EXPECT_LT((n.norm(2, -1) - 1).abs().max().item<double>(), 1e-4);
      // Normals face the camera.
      EXPECT_LE((n * s.rays.index({s.sample.mask})).sum(-1).max().item<double>(), 1e-6);
    }
}

TEST(SampleFormat, WriteReadRoundTrip) {
  const auto cam = camera::parse_camera("EQUIRECTANGULAR 64 32");
  const auto s = synth::synthesize(SceneKind::kOutdoor, 5, cam);
  const auto dir = fresh_dir("roundtrip");
  synth::write_synth_sample(dir.string(), s);
  const auto back = read_sample(dir.string());
  EXPECT_EQ(back.camera, cam);
  EXPECT_TRUE(back.metric);
  EXPECT_TRUE(at::equal(back.mask, s.sample.mask));
  EXPECT_TRUE(at::equal(back.distance, s.sample.distance));
  EXPECT_LT((back.image - s.sample.image).abs().max().item<double>(), 1e-6);
  EXPECT_TRUE(at::equal(io::read_npy((dir / "depth.npy").string()), s.depth));

  // Without distance.npy the planar depth is used: same distances on forward rays.
  fs::remove(dir / "distance.npy");
  const auto from_depth = read_sample(dir.string());
  const auto forward = s.sample.mask & (s.rays.select(-1, 2) > 0.2);
  EXPECT_LT(
      (from_depth.distance - s.sample.distance).masked_select(forward).abs().max().item<double>(),
      1e-4);
}

TEST(SampleFormat, BadFoldersAreRejectedWithTheirReason) {
  const auto cam = camera::parse_camera("PINHOLE 16 12 14 14 8 6");
  const auto good = synth::synthesize(SceneKind::kObject, 2, cam);
  const auto expect_error = [&](const std::string& name,
                                const std::function<void(const fs::path&)>& spoil,
                                const std::string& reason) {
    const auto dir = fresh_dir("bad_" + name);
    write_sample(dir.string(), good.sample);
    spoil(dir);
    try {
      read_sample(dir.string());
      ADD_FAILURE() << name << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << name << ": " << e.what();
    }
  };
  expect_error(
      "no_meta", [](const fs::path& d) { fs::remove(d / "meta.json"); }, "meta.json");
  expect_error(
      "no_image", [](const fs::path& d) { fs::remove(d / "image.png"); }, "image");
  expect_error(
      "no_depth", [](const fs::path& d) { fs::remove(d / "distance.npy"); }, "distance.npy");
  expect_error(
      "corrupt_image", [](const fs::path& d) { std::ofstream(d / "image.png") << "nope"; },
      "image.png");
  expect_error(
      "nan",
      [&](const fs::path& d) {
        auto t = good.sample.distance.clone();
        t[3][4] = NAN;
        io::write_npy((d / "distance.npy").string(), t);
      },
      "NaN");
  expect_error(
      "negative",
      [&](const fs::path& d) {
        auto t = good.sample.distance.clone();
        t[3][4] = -1;
        io::write_npy((d / "distance.npy").string(), t);
      },
      "negative");
  expect_error(
      "size",
      [&](const fs::path& d) {
        io::write_npy((d / "distance.npy").string(), at::ones({5, 5}));
      },
      "shape");
  expect_error(
      "camera",
      [](const fs::path& d) {
        std::ofstream(d / "meta.json")
            << R"({"camera": "NO_SUCH_MODEL 16 12 1 2 3", "metric": true})";
      },
      "camera");
}

TEST(SampleTransforms, CropAndResizeKeepThePointsOfTheScene) {
  const auto cam = camera::parse_camera("OPENCV 96 72 60 61 47.5 36.5 -0.2 0.05 0.001 -0.001");
  const auto s = synth::synthesize(SceneKind::kObject, 4, cam).sample;
  const auto points = [](const Sample& x) {
    const auto rays = x.camera.ray_map(at::kFloat);
    return rays.rays * x.distance.unsqueeze(-1);
  };
  // Crop: exactly the same points at the same pixels.
  const auto c = crop_sample(s, 10, 7, 50, 40);
  EXPECT_LT((points(c) - points(s).narrow(0, 7, 40).narrow(1, 10, 50)).abs().max().item<double>(),
            1e-5);
  EXPECT_THROW(crop_sample(s, 60, 0, 50, 10), std::invalid_argument);

  // Resize by 1/2: each new pixel's point is the source pixel's point it was taken from,
  // a sub-pixel away from the new pixel centre, so compare with the re-rendered truth.
  const auto r = resize_sample(s, 48, 36);
  const auto truth = synth::synthesize(SceneKind::kObject, 4, r.camera).sample;
  const auto both = r.mask & truth.mask;
  const auto error = (points(r) - points(truth)).norm(2, -1).masked_select(both);
  const auto scale = truth.distance.masked_select(both);
  // Most pixels lie on smooth surfaces: the median error is a fraction of a pixel's footprint.
  EXPECT_LT((error / scale).median().item<double>(), 0.02);
}

TEST(SynthCli, WritesOneFolderPerSeedAndRejectsBadInput) {
  const auto dir = fresh_dir("cli");
  const auto run = [&](const std::string& args) { return test::run_omnipoint(args, dir / "cli"); };
  const test::CliRun ok =
      run("synth --camera 'PINHOLE 32 24 30 30 16 12' --scene outdoor --seed 7 --count 2 --out " +
          dir.string());
  ASSERT_EQ(ok.status, 0) << ok.err;
  EXPECT_TRUE(fs::exists(dir / "000007" / "image.png"));
  EXPECT_TRUE(fs::exists(dir / "000008" / "meta.json"));
  EXPECT_EQ(read_sample((dir / "000008").string()).camera.width(), 32);
  const test::CliRun bad_scene =
      run("synth --camera 'PINHOLE 32 24 30 30 16 12' --scene moon --out " + dir.string());
  EXPECT_NE(bad_scene.status, 0);
  EXPECT_NE(bad_scene.err.find("moon"), std::string::npos) << bad_scene.err;
  EXPECT_NE(run("synth --camera 'PINHOLE 32' --out " + dir.string()).status, 0);
}

}  // namespace
}  // namespace omnipoint::data
