// Map-style datasets (data/dataset.h): the sample-folder and MoGe readers, the registry of
// formats, the synthetic engine as a dataset, and fitting a sample to a training size.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "omnipoint/data/dataset.h"
#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/moge_format.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/synth_dataset.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;

const char* const kPinhole = "PINHOLE 48 36 40 40 24 18";

void write_object_sample(const fs::path& folder, uint64_t seed) {
  write_sample(
      folder.string(),
      synth::synthesize(synth::SceneKind::kObject, seed, camera::parse_camera(kPinhole)).sample);
}

TEST(Dataset, SampleFoldersInNameOrderWithoutPartialOnes) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_dataset_folders");
  write_object_sample(root / "b", 2);
  write_object_sample(root / "a", 1);
  write_object_sample(root / ".c.partial-Xy12z9", 3);  // still being written (io/staged_folder.h)
  const std::unique_ptr<Dataset> dataset = open_dataset("folders", {root.string()});
  ASSERT_EQ(dataset->size(), 2);
  EXPECT_EQ(dataset->item_name({0, 0}), (root / "a").string());
  EXPECT_EQ(dataset->item_name({1, 0}), (root / "b").string());
  const Sample item = dataset->item({1, 0});
  const Sample read = read_sample((root / "b").string());
  EXPECT_TRUE(at::equal(item.image, read.image));
  EXPECT_TRUE(at::equal(item.distance, read.distance));
  // A uniform index, one draw of the generator.
  synth::Random random(7, 0), same(7, 0);
  EXPECT_EQ(dataset->draw(random).index, same.integer(0, 1));

  // A bad item is a SampleError naming it, the one error a caller skips an item for.
  at::Tensor distance = read.distance.clone();
  distance[0][0] = NAN;
  io::write_npy((root / "b" / "distance.npy").string(), distance);
  try {
    dataset->item({1, 0});
    FAIL() << "a NaN distance was read";
  } catch (const SampleError& e) {
    EXPECT_NE(std::string(e.what()).find((root / "b").string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("NaN"), std::string::npos) << e.what();
  }
  fs::remove_all(root / "a");
  EXPECT_THROW(dataset->item({0, 0}), SampleError);  // gone since it was listed

  fs::create_directories(root / "empty");
  EXPECT_THROW(open_dataset("folders", {(root / "empty").string()}), std::runtime_error);
  EXPECT_THROW(open_dataset("folders", {(root / "missing").string()}), std::runtime_error);
  fs::remove_all(root);
}

TEST(Dataset, MogeBenchmarkInstancesInIndexOrder) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_dataset_moge");
  for (const std::string name : {"first", "second"}) {
    fs::create_directories(root / name);
    // PNG bytes in image.jpg: the reader decodes by content.
    io::write_image_png((root / name / "image.jpg").string(), at::rand({12, 16, 3}));
    write_moge_depth((root / name / "depth.png").string(),
                     at::full({12, 16}, name == "first" ? 2.0F : 3.0F));
    std::ofstream(root / name / "meta.json")
        << R"({"intrinsics": [[0.75, 0, 0.5], [0, 1.0, 0.5], [0, 0, 1]]})";
  }
  std::ofstream(root / ".index.txt") << "second\nfirst\n";
  const std::unique_ptr<Dataset> metric = open_dataset("moge", {root.string(), true});
  ASSERT_EQ(metric->size(), 2);
  EXPECT_EQ(metric->item_name({0, 0}), (root / "second").string());
  const Sample second = metric->item({0, 0});
  EXPECT_TRUE(second.metric);
  const at::Tensor z = second.distance * second.camera.ray_map(at::kFloat).rays.select(-1, 2);
  EXPECT_LT((z - 3).masked_select(second.mask).abs().max().item<double>(), 1e-2);
  EXPECT_FALSE(open_dataset("moge", {root.string(), false})->item({1, 0}).metric);
  fs::remove(root / "first" / "depth.png");
  EXPECT_THROW(metric->item({1, 0}), SampleError);
  fs::remove_all(root);
}

// A dataset of one constant sample, as a reader of another format would be.
class ConstantDataset : public Dataset {
 public:
  explicit ConstantDataset(std::string path) : path_(std::move(path)) {}
  int64_t size() const override { return 3; }
  Sample item(const ItemIndex& /*index*/) const override {
    return synth::synthesize(synth::SceneKind::kIndoor, 1, camera::parse_camera(kPinhole)).sample;
  }
  std::string item_name(const ItemIndex& index) const override {
    return path_ + "#" + std::to_string(index.index);
  }

 private:
  std::string path_;
};

TEST(Dataset, FormatsAreRegisteredByName) {
  const std::vector<std::string> builtin = {
      "arkitscenes", "folders",       "hypersim",     "images",    "kitti-raw",
      "kitti360",    "matterport360", "moge",         "pano3d",    "panosuncg",
      "rig-log",     "stanford2d3d",  "structured3d", "tartanair", "vkitti2"};
  EXPECT_EQ(dataset_formats(), builtin);
  try {
    open_dataset("tar", {"x"});
    FAIL() << "an unknown format was opened";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "dataset format \"tar\": unknown (known: arkitscenes, folders, hypersim, images, "
              "kitti-raw, kitti360, matterport360, moge, pano3d, panosuncg, rig-log, stanford2d3d, "
              "structured3d, tartanair, vkitti2)");
  }
  register_dataset_format("constant", [](const DatasetLocation& location) {
    return std::make_unique<ConstantDataset>(location.path);
  });
  const std::unique_ptr<Dataset> dataset = open_dataset("constant", {"somewhere"});
  EXPECT_EQ(dataset->size(), 3);
  EXPECT_EQ(dataset->item_name({2, 0}), "somewhere#2");
  std::vector<std::string> with_constant = builtin;
  with_constant.insert(with_constant.begin() + 1, "constant");  // after "arkitscenes"
  EXPECT_EQ(dataset_formats(), with_constant);
  EXPECT_THROW(register_dataset_format("constant",
                                       [](const DatasetLocation& location) {
                                         return std::make_unique<ConstantDataset>(location.path);
                                       }),
               std::invalid_argument);
  EXPECT_THROW(register_dataset_format("", nullptr), std::invalid_argument);
}

TEST(Dataset, FormatsDeclareTheirOptionsAndOthersAreRefused) {
  for (const DatasetFormat& format : builtin_dataset_formats()) {
    EXPECT_FALSE(format.summary.empty()) << format.name;
    EXPECT_TRUE(format.open) << format.name;
  }
  DatasetFormat format;
  format.name = "with_options";
  format.summary = "items named after the option";
  format.options = {{"camera", "which camera (default: left)"}};
  format.open = [](const DatasetLocation& location) {
    return std::make_unique<ConstantDataset>(option_or(location, "camera", "left") + "@" +
                                             location.split);
  };
  register_dataset_format(format);
  DatasetLocation location{"root"};
  EXPECT_EQ(open_dataset("with_options", location)->item_name({0, 0}), "left@#0");
  location.split = "val";
  location.options = {{"camera", "right"}};
  EXPECT_EQ(open_dataset("with_options", location)->item_name({1, 0}), "right@val#1");
  location.options = {{"camera", "right"}, {"cam", "x"}};
  try {
    open_dataset("with_options", location);
    FAIL() << "an undeclared option was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "dataset format \"with_options\": no option \"cam\" (its options: camera)");
  }
}

// Items are (scene kind, camera) pairs; each draw picks the kind, the camera, then the seed
// of the scene instance, and the item is that scene through that camera.
TEST(SynthDataset, DrawsAKindACameraAndASceneSeed) {
  const camera::Camera pinhole = camera::parse_camera("PINHOLE 28 21 20 20 14 10.5");
  const camera::Camera panorama = camera::parse_camera("EQUIRECTANGULAR 28 14");
  const synth::SynthDataset dataset({synth::SceneKind::kIndoor, synth::SceneKind::kObject},
                                    {pinhole, panorama});
  EXPECT_EQ(dataset.size(), 4);
  synth::Random random(3, 0), same(3, 0);
  const ItemIndex index = dataset.draw(random);
  const int kind = same.integer(0, 1), camera = same.integer(0, 1);
  EXPECT_EQ(index.index, kind * 2 + camera);
  EXPECT_EQ(index.seed, same.next_u64());
  const Sample item = dataset.item({3, 42});  // object, panorama
  const Sample expected = synth::synthesize(synth::SceneKind::kObject, 42, panorama).sample;
  EXPECT_TRUE(at::equal(item.image, expected.image));
  EXPECT_TRUE(at::equal(item.distance, expected.distance));
  EXPECT_EQ(dataset.item_name({3, 42}), "synth:object:42");
  EXPECT_THROW(synth::SynthDataset({}, {pinhole}), std::invalid_argument);
  EXPECT_THROW(synth::SynthDataset({synth::SceneKind::kIndoor}, {}), std::invalid_argument);
}

// The largest centred window of the target aspect ratio, resized: the camera follows the
// pixels, and a sample of the target size is kept as it is.
TEST(SampleTransforms, FitTakesTheCentreWindowOfTheAspectAndResizes) {
  const Sample sample =
      synth::synthesize(synth::SceneKind::kIndoor, 4, camera::parse_camera(kPinhole)).sample;
  const Sample same = fit_sample(sample, 48, 36);
  EXPECT_TRUE(at::equal(same.image, sample.image));
  const Sample square = fit_sample(sample, 18, 18);
  EXPECT_EQ(square.camera.to_spec(), sample.camera.cropped(6, 0, 36, 36).resized(18, 18).to_spec());
  const Sample expected = resize_sample(crop_sample(sample, 6, 0, 36, 36), 18, 18);
  EXPECT_TRUE(at::equal(square.image, expected.image));
  EXPECT_TRUE(at::equal(square.distance, expected.distance));
  const Sample wide = fit_sample(sample, 40, 10);  // 48x12 from rows 12..23
  EXPECT_EQ(wide.camera.to_spec(), sample.camera.cropped(0, 12, 48, 12).resized(40, 10).to_spec());
}

}  // namespace
}  // namespace omnipoint::data
