// The training loader: mixing, token-budget sizes with consistent cameras, augmentation,
// reproducible prefetching, and bad-sample handling.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "omnipoint/data/loader.h"
#include "omnipoint/data/photometric.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::data {
namespace {
namespace fs = std::filesystem;

// A folder of `good` synthetic samples and `bad` ones with NaN distances.
fs::path make_folder(const std::string& name, int good, int bad) {
  const auto root = fs::temp_directory_path() / ("omnipoint_loader_" + name);
  fs::remove_all(root);
  const auto cam = camera::parse_camera("PINHOLE 48 36 40 40 24 18");
  for (int i = 0; i < good + bad; ++i) {
    const auto dir = root / ("s" + std::to_string(i));
    auto s = synth::synthesize(synth::SceneKind::kObject, i, cam);
    write_sample(dir.string(), s.sample);
    if (i >= good) {
      auto d = s.sample.distance.clone();
      d[0][0] = NAN;
      io::write_npy((dir / "distance.npy").string(), d);
    }
  }
  return root;
}

LoaderOptions small_options(const fs::path& folder) {
  LoaderOptions o;
  DataSource f;
  f.kind = "folder";
  f.path = folder.string();
  f.weight = 3;
  f.metric = true;
  DataSource s;
  s.kind = "synth";
  s.cameras = {"EQUIRECTANGULAR 64 32", "PINHOLE 40 30 30 30 20 15"};
  o.sources = {f, s};
  o.batch_size = 3;
  o.num_tokens = 20;
  o.patch_size = 8;
  o.seed = 9;
  return o;
}

TEST(Loader, BatchesHaveTheBudgetShapeAndConsistentLabels) {
  const auto folder = make_folder("shapes", 3, 1);
  Loader loader(small_options(folder));
  int from_synth = 0, from_folder = 0;
  for (int k = 0; k < 4; ++k) {
    const auto b = loader.next();
    const int64_t h = b.image.size(2), w = b.image.size(3);
    EXPECT_EQ(h % 8, 0);
    EXPECT_EQ(w % 8, 0);
    EXPECT_NEAR(double(h * w) / 64, 20, 8);
    ASSERT_EQ(b.image.sizes(), (at::IntArrayRef{3, 3, h, w}));
    EXPECT_EQ(b.rays.sizes(), (at::IntArrayRef{3, h, w, 3}));
    EXPECT_GE(b.image.min().item<double>(), 0.0);
    EXPECT_LE(b.image.max().item<double>(), 1.0);
    EXPECT_EQ(b.distance.masked_select(b.mask.logical_not()).abs().sum().item<double>(), 0.0);
    EXPECT_GT(b.distance.masked_select(b.mask).min().item<double>(), 0.0);
    EXPECT_TRUE(b.metric.all().item<bool>());
    for (int j = 0; j < 3; ++j) {
      EXPECT_EQ(b.cameras[j].width(), w);
      EXPECT_TRUE(at::equal(b.rays[j], b.cameras[j].ray_map(at::kFloat).rays));
      (b.sources[j].rfind("synth:", 0) == 0 ? from_synth : from_folder)++;
    }
  }
  EXPECT_GT(from_synth, 0);
  EXPECT_GT(from_folder, 0);
}

TEST(Loader, StreamIsReproducibleWhateverTheWorkerCount) {
  const auto folder = make_folder("repro", 3, 1);
  auto one = small_options(folder);
  one.workers = 1;
  auto three = small_options(folder);
  three.workers = 3;
  three.prefetch = 2;
  Loader a(one), b(three);
  for (int k = 0; k < 3; ++k) {
    const auto x = a.next(), y = b.next();
    EXPECT_EQ(x.sources, y.sources);
    EXPECT_TRUE(at::equal(x.image, y.image));
    EXPECT_TRUE(at::equal(x.distance, y.distance));
  }
}

TEST(Loader, BadSamplesAreSkippedAndCounted) {
  const auto folder = make_folder("bad", 1, 2);
  auto o = small_options(folder);
  o.sources.resize(1);  // the folder alone: draws hit the bad samples soon
  Loader loader(o);
  for (int k = 0; k < 3; ++k) {
    const auto b = loader.next();
    for (const auto& s : b.sources) EXPECT_EQ(fs::path(s).filename(), "s0");
  }
  const auto skipped = loader.skipped();
  int64_t nan = 0;
  for (const auto& [reason, count] : skipped)
    if (reason.find("NaN") != std::string::npos) nan += count;
  EXPECT_GE(nan, 1);
}

TEST(Loader, SourcesWithoutUsableSamplesAreErrors) {
  const auto only_bad = make_folder("only_bad", 0, 2);
  auto o = small_options(only_bad);
  o.sources.resize(1);
  Loader loader(o);
  EXPECT_THROW(loader.next(), std::runtime_error);

  const auto empty = fs::temp_directory_path() / "omnipoint_loader_empty";
  fs::create_directories(empty);
  auto e = small_options(empty);
  EXPECT_THROW(Loader{e}, std::runtime_error);
  auto no_camera = small_options(only_bad);
  no_camera.sources[1].cameras.clear();
  EXPECT_THROW(Loader{no_camera}, std::invalid_argument);
  auto bad_kind = small_options(only_bad);
  bad_kind.sources[0].kind = "tar";
  EXPECT_THROW(Loader{bad_kind}, std::invalid_argument);
}

TEST(Photometric, DeterministicBySeedAndInRange) {
  const auto image = at::rand({20, 24, 3});
  PhotometricOptions o;
  o.blur_probability = o.noise_probability = o.jpeg_probability = 1.0;
  const auto a = photometric_augment(image, o, 5), b = photometric_augment(image, o, 5);
  const auto c = photometric_augment(image, o, 6);
  EXPECT_TRUE(at::equal(a, b));
  EXPECT_FALSE(at::equal(a, c));
  EXPECT_EQ(a.sizes(), image.sizes());
  EXPECT_GE(a.min().item<double>(), 0.0);
  EXPECT_LE(a.max().item<double>(), 1.0);
  // With every effect off the image is unchanged.
  PhotometricOptions none{0, 0, 0, 0, 0, 0, 0};
  EXPECT_TRUE(at::allclose(photometric_augment(image, none, 1), image, 1e-6, 1e-6));
}

TEST(Loader, BatchImageSizeFollowsTheTokenBudget) {
  EXPECT_EQ(batch_image_size(600, 14, 1.0), (std::pair<int64_t, int64_t>{24 * 14, 24 * 14}));
  const auto [w, h] = batch_image_size(600, 14, 2.0);
  EXPECT_EQ(w, 35 * 14);
  EXPECT_EQ(h, 17 * 14);
  EXPECT_THROW(batch_image_size(0, 14, 1.0), std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::data
