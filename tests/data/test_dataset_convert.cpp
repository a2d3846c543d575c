// `data convert` (data/dataset_convert.h): a KITTI raw root and a Stanford2D3D root written in
// their native layouts, converted to sample folders, reopened with the "folders" format: the
// same samples (images, distances, masks, cameras exactly); the manifest; --every, --limit,
// --sequence, --camera; a bad item skipped with a warning; refusals (unknown format, an option
// the format lacks, an output that cannot be written or holds files), nothing half-written.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "driving_files.h"
#include "native_roots.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/dataset_convert.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/staged_folder.h"
#include "support/cli_run.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::expect_error;
using test::frame_stem;

using test::kitti_raw_sweep_path;
using test::kKittiRawDate;
using test::kKittiRawDrive;
using test::write_kitti_raw;
using test::write_stanford2d3d;

// The converted folder holds the same samples as the source dataset, item by item.
void expect_same_samples(const Dataset& source, const std::vector<int64_t>& indices,
                         const fs::path& out) {
  const std::unique_ptr<Dataset> converted = open_dataset("folders", {out.string()});
  ASSERT_EQ(converted->size(), static_cast<int64_t>(indices.size()));
  for (size_t k = 0; k < indices.size(); ++k) {
    const Sample truth = source.item({indices[k], 0});
    const Sample read = converted->item({static_cast<int64_t>(k), 0});
    const std::string what = source.item_name({indices[k], 0});
    EXPECT_EQ(read.camera, truth.camera) << what;
    EXPECT_TRUE(at::equal(read.distance, truth.distance)) << what;
    EXPECT_TRUE(at::equal(read.mask, truth.mask)) << what;
    EXPECT_TRUE(at::equal(read.image, truth.image)) << what;  // 8-bit PNG both ways
    EXPECT_EQ(read.metric, truth.metric) << what;
    EXPECT_TRUE(read.metric) << what;
    EXPECT_EQ(read.sparse_labels, truth.sparse_labels) << what;
  }
}

std::vector<nlohmann::json> manifest_of(const fs::path& out) {
  std::vector<nlohmann::json> lines;
  std::istringstream text(io::read_file((out / "manifest.jsonl").string()));
  for (std::string line; std::getline(text, line);) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

// Nothing but finished sample folders and the manifest.
void expect_no_staging(const fs::path& out) {
  for (const fs::directory_entry& entry : fs::directory_iterator(out))
    EXPECT_FALSE(io::is_staging_folder(entry.path())) << entry.path();
}

DatasetConvertOptions options_for(const std::string& format, const fs::path& root,
                                  const fs::path& out) {
  DatasetConvertOptions options;
  options.format = format;
  options.location.path = root.string();
  options.output_path = out.string();
  return options;
}

TEST(DatasetConvert, KittiRawFramesReopenAsTheSameSamples) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = write_kitti_raw("omnipoint_convert_kitti_raw", 3);
  const fs::path out = root.parent_path() / (root.filename().string() + "_out");
  fs::remove_all(out);
  const DatasetConvertReport report = DatasetConvert(options_for("kitti-raw", root, out)).Run();
  EXPECT_EQ(report.items, 3);
  EXPECT_EQ(report.converted, 3);
  EXPECT_EQ(report.kept, 0);
  EXPECT_TRUE(report.skipped.empty());
  EXPECT_EQ(report.manifest_path, (out / "manifest.jsonl").string());
  const std::unique_ptr<Dataset> source = open_dataset("kitti-raw", {root.string()});
  expect_same_samples(*source, {0, 1, 2}, out);
  expect_no_staging(out);

  // The manifest: one line per item, its folder (named after the item), name and sources.
  const std::vector<nlohmann::json> manifest = manifest_of(out);
  ASSERT_EQ(manifest.size(), 3u);
  for (int64_t i = 0; i < 3; ++i) {
    const nlohmann::json& line = manifest[static_cast<size_t>(i)];
    EXPECT_EQ(line["sample"], std::string(kKittiRawDate) + "-" + kKittiRawDrive +
                                  "-image_02-data-" + frame_stem(static_cast<int>(i)));
    EXPECT_EQ(line["item"], source->item_name({i, 0}));
    EXPECT_EQ(line["sources"], nlohmann::json(source->item_sources({i, 0})));
    const nlohmann::json meta = nlohmann::json::parse(
        io::read_file((out / line["sample"].get<std::string>() / "meta.json").string()));
    EXPECT_EQ(meta["metric"], true);
    EXPECT_EQ(meta["camera"], source->item({i, 0}).camera.to_spec());
    EXPECT_EQ(meta["source"]["format"], "kitti-raw");
  }

  // --camera names the dataset's camera.
  DatasetConvertOptions right = options_for("kitti-raw", root, out.string() + "_right");
  right.camera = "image_03";
  fs::remove_all(right.output_path);
  EXPECT_EQ(DatasetConvert(right).Run().converted, 3);
  expect_same_samples(
      *open_dataset("kitti-raw", {root.string(), false, "", {{"camera", "image_03"}}}), {0, 1, 2},
      right.output_path);
}

TEST(DatasetConvert, Stanford2d3dPanoramasAndSequence) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = write_stanford2d3d("omnipoint_convert_stanford");
  const fs::path out = root.parent_path() / (root.filename().string() + "_out");
  fs::remove_all(out);
  EXPECT_EQ(DatasetConvert(options_for("stanford2d3d", root, out)).Run().converted, 2);
  expect_same_samples(*open_dataset("stanford2d3d", {root.string()}), {0, 1}, out);

  // --sequence: the format's own scene names (areas).
  DatasetConvertOptions area = options_for("stanford2d3d", root, out.string() + "_5a");
  area.sequence = "area_5a";
  fs::remove_all(area.output_path);
  EXPECT_EQ(DatasetConvert(area).Run().converted, 1);
  const std::vector<nlohmann::json> manifest = manifest_of(area.output_path);
  ASSERT_EQ(manifest.size(), 1u);
  EXPECT_EQ(manifest[0]["sample"],
            "area_5a-pano-rgb-camera_0a1b_area_5a_office_1_frame_equirectangular_domain_rgb");
  expect_same_samples(
      *open_dataset("stanford2d3d", {root.string(), false, "", {{"sequence", "area_5a"}}}), {0},
      area.output_path);
}

TEST(DatasetConvert, EveryLimitAndRerunsByFolderName) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = write_kitti_raw("omnipoint_convert_every", 7);
  const fs::path out = root.parent_path() / (root.filename().string() + "_out");
  fs::remove_all(out);
  DatasetConvertOptions options = options_for("kitti-raw", root, out);
  options.every = 3;  // frames 0, 3, 6 ...
  options.limit = 2;  // ... the first two
  DatasetConvertReport report = DatasetConvert(options).Run();
  EXPECT_EQ(report.items, 2);
  EXPECT_EQ(report.converted, 2);
  const std::unique_ptr<Dataset> source = open_dataset("kitti-raw", {root.string()});
  expect_same_samples(*source, {0, 3}, out);

  // A folder holding files is refused; --resume keeps the converted items, --overwrite writes
  // them anew (same names: a rerun matches).
  options.limit = 0;
  expect_error([&] { DatasetConvert(options).Run(); }, {out.string(), "--resume", "--overwrite"});
  options.resume = true;
  const fs::file_time_type written = fs::last_write_time(out / manifest_of(out)[0]["sample"]);
  report = DatasetConvert(options).Run();
  EXPECT_EQ(report.items, 3);
  EXPECT_EQ(report.kept, 2);
  EXPECT_EQ(report.converted, 1);
  EXPECT_EQ(fs::last_write_time(out / manifest_of(out)[0]["sample"]), written);
  expect_same_samples(*source, {0, 3, 6}, out);
  EXPECT_EQ(manifest_of(out).size(), 3u);
  options.resume = false;
  options.overwrite = true;
  report = DatasetConvert(options).Run();
  EXPECT_EQ(report.converted, 3);
  expect_same_samples(*source, {0, 3, 6}, out);
  expect_no_staging(out);
}

TEST(DatasetConvert, ABadItemIsSkippedAndNamed) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = write_kitti_raw("omnipoint_convert_bad_item", 3);
  // Frame 1's sweep truncated mid-record.
  const std::string bytes = io::read_file(kitti_raw_sweep_path(root, 1).string());
  test::write_text(kitti_raw_sweep_path(root, 1), bytes.substr(0, bytes.size() - 6));
  const fs::path out = root.parent_path() / (root.filename().string() + "_out");
  fs::remove_all(out);
  struct Warnings : DatasetConvertObserver {
    std::vector<std::string> lines;
    int64_t done = 0;
    void on_skipped(const ConvertedItem&, const std::string& why) override { lines.push_back(why); }
    void on_item_done(int64_t) override { ++done; }
  } warnings;
  const DatasetConvertReport report =
      DatasetConvert(options_for("kitti-raw", root, out), &warnings).Run();
  EXPECT_EQ(report.converted, 2);
  ASSERT_EQ(report.skipped.size(), 1u);
  EXPECT_EQ(warnings.lines, report.skipped);
  EXPECT_EQ(warnings.done, 3);
  EXPECT_NE(report.skipped[0].find(frame_stem(1) + ".bin"), std::string::npos) << report.skipped[0];
  EXPECT_EQ(report.skipped[0].find('\n'), std::string::npos) << report.skipped[0];
  expect_same_samples(*open_dataset("kitti-raw", {root.string()}), {0, 2}, out);
  EXPECT_EQ(manifest_of(out).size(), 2u);
  expect_no_staging(out);

  // Nothing converted: an error, and no output folder left.
  DatasetConvertOptions only_bad = options_for("kitti-raw", root, out.string() + "_none");
  fs::remove_all(only_bad.output_path);
  only_bad.every = 5;  // frame 0 ...
  test::write_text(kitti_raw_sweep_path(root, 0), bytes.substr(0, 5));
  expect_error([&] { DatasetConvert(only_bad).Run(); },
               {"nothing converted", "1 of 1", frame_stem(0) + ".bin"});
  EXPECT_FALSE(fs::exists(only_bad.output_path));
}

TEST(DatasetConvert, RefusalsNameTheProblem) {
  const fs::path scratch = test::fresh_process_dir("omnipoint_convert_refusals");
  const fs::path stanford = write_stanford2d3d("omnipoint_convert_refusals_root");
  expect_error([&] { DatasetConvert(options_for("kitti-rawx", stanford, scratch / "a")).Run(); },
               {"kitti-rawx", "unknown", "kitti-raw"});
  DatasetConvertOptions camera = options_for("stanford2d3d", stanford, scratch / "b");
  camera.camera = "image_02";
  expect_error([&] { DatasetConvert(camera).Run(); }, {"--camera", "stanford2d3d"});
  camera.camera.clear();
  camera.location.options["sequence"] = "area_1";
  camera.sequence = "area_5a";
  expect_error([&] { DatasetConvert(camera).Run(); }, {"--sequence", "sequence"});
  for (const auto& [field, set] :
       std::vector<std::pair<std::string, std::function<void(DatasetConvertOptions&)>>>{
           {"every", [](DatasetConvertOptions& o) { o.every = 0; }},
           {"limit", [](DatasetConvertOptions& o) { o.limit = -1; }},
           {"output folder", [](DatasetConvertOptions& o) { o.output_path.clear(); }},
           {"resume", [](DatasetConvertOptions& o) { o.resume = o.overwrite = true; }}}) {
    DatasetConvertOptions bad = options_for("stanford2d3d", stanford, scratch / "c");
    set(bad);
    expect_error([&] { DatasetConvert{bad}; }, {field});
  }
  if (!io::image_io_available()) return;
  // An output under a file cannot be created.
  test::write_text(scratch / "file", "x");
  expect_error(
      [&] {
        DatasetConvert(options_for("stanford2d3d", stanford, scratch / "file" / "out")).Run();
      },
      {"cannot create the output folder", "file"});
  expect_error(
      [&] { DatasetConvert(options_for("stanford2d3d", stanford, scratch / "file")).Run(); },
      {"not a folder"});
}

TEST(DatasetConvert, FolderNamesFromItemNames) {
  EXPECT_EQ(sample_folder_name("/data/kitti/2011_09_26/drive/image_02/data/0000000001.png",
                               "/data/kitti"),
            "2011_09_26-drive-image_02-data-0000000001");
  EXPECT_EQ(sample_folder_name("/data/kitti/./a/b.png", "/data/kitti/"), "a-b");
  EXPECT_EQ(sample_folder_name("area_1/pano/rgb/x y#z.png", "root"), "area_1-pano-rgb-x_y_z");
  EXPECT_EQ(sample_folder_name("/elsewhere/.hidden/x.png", "/data"), "elsewhere-.hidden-x");
  EXPECT_EQ(sample_folder_name(".x.png", ""), "_x");
  const std::string long_name = sample_folder_name(std::string(300, 'a') + "/frame_9.png", "");
  EXPECT_EQ(long_name.size(), 200u);
  EXPECT_EQ(long_name.substr(long_name.size() - 7), "frame_9");
}

TEST(DataConvertCommand, SummaryWarningsAndErrors) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = write_kitti_raw("omnipoint_convert_cli", 2);
  const std::string bytes = io::read_file(kitti_raw_sweep_path(root, 1).string());
  test::write_text(kitti_raw_sweep_path(root, 1), bytes.substr(0, bytes.size() - 6));
  const fs::path out = root.parent_path() / (root.filename().string() + "_out");
  fs::remove_all(out);
  const fs::path scratch = root.parent_path() / (root.filename().string() + "_run");
  test::CliRun run = test::run_omnipoint("data convert --format kitti-raw --root " + root.string() +
                                             " --out " + out.string() + " --camera image_02",
                                         scratch);
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "converted 1, kept 0, skipped 1 of 2 items into " + out.string() + " (" +
                         (out / "manifest.jsonl").string() + ")\n");
  EXPECT_NE(run.err.find("omnipoint: warning: "), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("skipped " + root.string()), std::string::npos) << run.err;
  EXPECT_NE(run.err.find(frame_stem(1) + ".bin"), std::string::npos) << run.err;

  run = test::run_omnipoint(
      "data convert --format kitti-raw --root " + root.string() + " --out " + out.string(),
      scratch);
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(run.err.find('\n'), run.err.size() - 1) << run.err;
  EXPECT_NE(run.err.find("--resume"), std::string::npos) << run.err;

  run = test::run_omnipoint(
      "data convert --format nope --root " + root.string() + " --out " + out.string() + "_nope",
      scratch);
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(run.err.rfind("omnipoint: error: dataset format \"nope\": unknown", 0), 0u) << run.err;
  EXPECT_FALSE(fs::exists(out.string() + "_nope"));
}

}  // namespace
}  // namespace omnipoint::data
