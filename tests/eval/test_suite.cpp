// Benchmark suites (eval/suite.h): the suite file's strict reading, the shipped paper suite and
// its split lists opened by their readers, and `omnipoint eval --suite` on a data root of
// synthetic stand-ins written in the native layouts (MoGe, KITTI-360 with DAC's list,
// Stanford2D3D with DA²'s and UniFuse's lists, PanoSUNCG), scored by baselines whose scores are
// known in closed form; sets not there are named, malformed suites give one error line.
#include <gtest/gtest.h>

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/data/moge_format.h"
#include "omnipoint/eval/eval_job.h"
#include "omnipoint/eval/suite.h"
#include "omnipoint/io/image.h"
#include "support/cli_run.h"
#include "support/expect_error.h"
#include "support/scratch_dir.h"

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/imgcodecs.hpp>
#endif

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using omnipoint::eval::parse_suite;
using omnipoint::eval::read_suite;
using omnipoint::eval::Suite;

const std::string kPaperSuite = std::string(OMNIPOINT_SOURCE_DIR) + "/benchmarks/paper_suite.json";

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string suite_error(const std::string& text) {
  try {
    parse_suite(text, "suite.json", "/suites");
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "(no error)";
}

// A one-set suite whose set is `set` (JSON members), for the error cases.
std::string one_set(const std::string& set) {
  return R"({"name": "s", "sets": [{)" + set + "}]}";
}
const std::string kSet = R"("name": "A", "group": "360°", "format": "stanford2d3d", "root": "a")";

TEST(SuiteFile, ReadsEveryField) {
  const Suite suite = parse_suite(
      R"({"name": "s", "columns": {"depth": "depth_affine_invariant"},
          "sets": [{"name": "A", "group": "360°", "format": "stanford2d3d", "root": "a",
                    "split": "lists/a.txt", "options": {"sequence": "area_1"},
                    "modes": ["none", "+K"], "group_mean": false},
                   {"name": "B", "group": "S.FoV", "format": "moge", "root": "b/c",
                    "metric": false, "modes": ["none"]}]})",
      "suite.json", "/suites");
  EXPECT_EQ(suite.name, "s");
  EXPECT_EQ(suite.columns.depth, "depth_affine_invariant");
  EXPECT_EQ(suite.columns.points, "points_scale_invariant");  // defaults
  EXPECT_EQ(suite.columns.metric, "depth_metric");
  ASSERT_EQ(suite.sets.size(), 2u);
  EXPECT_EQ(suite.sets[0].split, "/suites/lists/a.txt");  // relative to the suite's folder
  EXPECT_EQ(suite.sets[0].options.at("sequence"), "area_1");
  EXPECT_EQ(suite.sets[0].modes, (std::vector<std::string>{"none", "+K"}));
  EXPECT_FALSE(suite.sets[0].group_mean);
  EXPECT_TRUE(suite.sets[0].metric);
  EXPECT_EQ(suite.sets[1].root, "b/c");
  EXPECT_FALSE(suite.sets[1].metric);
  EXPECT_TRUE(suite.sets[1].group_mean);
  EXPECT_TRUE(suite.sets[1].split.empty());
}

TEST(SuiteFile, MalformedGivesOneLineNamingTheKey) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"{", "suite.json: not JSON"},
      {"[]", "suite.json: expected a JSON object"},
      {R"({"sets": []})", "suite.json: name: missing"},
      {R"({"name": "s"})", "suite.json: sets: missing"},
      {R"({"name": "s", "sets": {}})", "suite.json: sets: expected a list of sets"},
      {R"({"name": "s", "sets": [], "extra": 1})", "suite.json: extra: unknown key"},
      {R"({"name": "s", "columns": {"depth": "depth"}, "sets": []})",
       "suite.json: columns.depth: \"depth\" is no protocol entry"},
      {R"({"name": "s", "sets": [3]})", "suite.json: sets[0]: expected an object"},
      {one_set(R"("name": "A", "group": "S.FoV", "format": "moge", "modes": ["none"])"),
       "suite.json: sets[0].root: missing"},
      {one_set(kSet + R"(, "modes": ["none"], "group": 1)"), "sets[0].group"},
      {one_set(R"("name": "A", "group": "wide", "format": "moge", "root": "a", "modes": ["none"])"),
       "suite.json: sets[0].group: expected \"S.FoV\", \"L.FoV\" or \"360°\""},
      {one_set(
           R"("name": "A", "group": "S.FoV", "format": "nope", "root": "a", "modes": ["none"])"),
       "suite.json: sets[0].format: \"nope\" is no dataset format"},
      {one_set(kSet + R"(, "modes": ["none"], "options": {"camera": "x"})"),
       "suite.json: sets[0].options.camera: format \"stanford2d3d\" has no such option"},
      {one_set(kSet + R"(, "modes": ["none"], "options": {"sequence": 3})"),
       "suite.json: sets[0].options.sequence: expected a string"},
      {one_set(kSet + R"(, "modes": ["+K"])"), "suite.json: sets[0].modes: must hold \"none\""},
      {one_set(kSet + R"(, "modes": ["none", "+X"])"),
       "suite.json: sets[0].modes[1]: expected \"none\", \"+K\", \"+D\" or \"+K+D\""},
      {one_set(kSet + R"(, "modes": ["none", "none"])"),
       "suite.json: sets[0].modes[1]: listed twice"},
      {one_set(kSet + R"(, "modes": ["none"], "metric": "yes")"),
       "suite.json: sets[0].metric: expected true or false"},
      {one_set(kSet + R"(, "modes": ["none"], "colour": "red")"),
       "suite.json: sets[0].colour: unknown key"},
      {one_set(
           R"("name": "a/b", "group": "S.FoV", "format": "moge", "root": "a", "modes": ["none"])"),
       "suite.json: sets[0].name: \"a/b\" must not be a path"},
      {one_set(
           R"("name": "A", "group": "S.FoV", "format": "moge", "root": "/a", "modes": ["none"])"),
       "suite.json: sets[0].root: must be relative to the data root"},
      {R"({"name": "s", "sets": [{)" + kSet + R"(, "modes": ["none"]}, {)" + kSet +
           R"(, "modes": ["none"]}]})",
       "suite.json: sets[1].name: \"A\" is the name of an earlier set"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string error = suite_error(text);
    EXPECT_NE(error.find(expected), std::string::npos) << text << "\n -> " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
  omnipoint::test::expect_error<std::invalid_argument>(
      [] { read_suite("/no/such/suite.json"); }, {"suite /no/such/suite.json: cannot be read"});
}

// The paper's three groups: the eight MoGe sets, KITTI-360 with DAC's list, Stanford2D3D and
// PanoSUNCG with DA²'s lists and Stanford2D3D with UniFuse's fold 1 outside the group's mean.
TEST(PaperSuite, HoldsThePapersGroups) {
  const Suite suite = read_suite(kPaperSuite);
  std::map<std::string, std::vector<std::string>> groups;
  for (const auto& set : suite.sets) {
    groups[set.group].push_back(set.name);
    if (!set.split.empty()) {
      EXPECT_TRUE(fs::is_regular_file(set.split)) << set.split;
    }
    if (set.format == "moge") {
      EXPECT_TRUE(set.split.empty());  // MoGe's own .index.txt
    }
  }
  EXPECT_EQ(groups["S.FoV"], (std::vector<std::string>{"NYUv2", "KITTI", "ETH3D", "iBims-1", "GSO",
                                                       "Sintel", "DIODE", "HAMMER"}));
  EXPECT_EQ(groups["L.FoV"], (std::vector<std::string>{"KITTI-360"}));
  EXPECT_EQ(groups["360°"],
            (std::vector<std::string>{"Stanford2D3D", "PanoSUNCG", "Stanford2D3D-UniFuse-fold1"}));
  for (const auto& set : suite.sets) {
    EXPECT_EQ(set.group_mean, set.name != "Stanford2D3D-UniFuse-fold1") << set.name;
    // MoGe's configs give GSO and Sintel no depth unit: their depth is not metric.
    EXPECT_EQ(set.metric, set.name != "GSO" && set.name != "Sintel") << set.name;
  }
}

// The lines of a shipped list.
std::vector<std::vector<std::string>> list_lines(const std::string& file) {
  std::vector<std::vector<std::string>> lines;
  std::ifstream stream(std::string(OMNIPOINT_SOURCE_DIR) + "/benchmarks/splits/" + file);
  for (std::string line; std::getline(stream, line);) {
    std::istringstream fields(line);
    std::vector<std::string> parts;
    for (std::string field; fields >> field;) parts.push_back(field);
    if (!parts.empty()) lines.push_back(parts);
  }
  return lines;
}

// An empty file at each of a line's path fields (those with a folder).
void touch_paths(const fs::path& root, const std::vector<std::vector<std::string>>& lines) {
  for (const auto& line : lines)
    for (const std::string& field : line)
      if (field.find('/') != std::string::npos) write_text(root / field, "");
}

// Each shipped list, opened by its set's reader on a root holding an empty file at every path
// the native layout has for its lines: every line becomes one item (the readers check at open
// that each item's files exist; their contents are read only when an item is).
TEST(PaperSuite, ShippedListsOpenWithTheirReaders) {
  const Suite suite = read_suite(kPaperSuite);
  const fs::path root = omnipoint::test::fresh_process_dir("omnipoint_paper_lists");
  const auto dac = list_lines("kitti360_val_fisheye_dac.txt");
  const auto da2_stanford = list_lines("stanford2d3d_da2.txt");
  const auto unifuse = list_lines("stanford2d3d_unifuse_fold1_test.txt");
  const auto da2_suncg = list_lines("panosuncg_da2.txt");
  EXPECT_EQ(dac.size(), 2304u);
  EXPECT_EQ(da2_stanford.size(), 1413u);
  EXPECT_EQ(unifuse.size(), 373u);
  EXPECT_EQ(da2_suncg.size(), 3944u);
  // DAC's and DA²'s lines name the files of the native layouts (PanoSUNCG's relative to
  // rotated/); UniFuse's name its own preprocessed folders, read here from the official ones.
  touch_paths(root / "KITTI-360", dac);
  touch_paths(root / "Stanford2D3D", da2_stanford);
  touch_paths(root / "PanoSUNCG" / "rotated", da2_suncg);
  const std::map<std::string, size_t> expected{{"KITTI-360", dac.size()},
                                               {"Stanford2D3D", da2_stanford.size()},
                                               {"Stanford2D3D-UniFuse-fold1", unifuse.size()},
                                               {"PanoSUNCG", da2_suncg.size()}};
  size_t checked = 0;
  for (const auto& set : suite.sets) {
    if (set.split.empty()) continue;
    omnipoint::data::DatasetLocation location{(root / set.root).string(), set.metric, set.split,
                                              set.options};
    const auto dataset = omnipoint::data::open_dataset(set.format, location);
    EXPECT_EQ(static_cast<size_t>(dataset->size()), expected.at(set.name)) << set.name;
    std::set<std::string> names;
    for (int64_t i = 0; i < dataset->size(); ++i) names.insert(dataset->item_name({i, 0}));
    EXPECT_EQ(names.size(), expected.at(set.name)) << set.name << ": items named twice";
    ++checked;
  }
  EXPECT_EQ(checked, expected.size());
  fs::remove_all(root);
}

#ifdef OMNIPOINT_WITH_OPENCV

constexpr int kPanoWidth = 32, kPanoHeight = 16;
constexpr double kConstant = 5.0;  // the constant baseline's distance (its default)

void write_png(const fs::path& path, const at::Tensor& values) {
  fs::create_directories(path.parent_path());
  omnipoint::io::write_image_png(path.string(), values);
}
at::Tensor grey_image(int64_t width, int64_t height) {
  return at::full({height, width, 3}, 128, at::kByte);
}

// NYUv2 in MoGe's layout: one pinhole instance seeing a sphere of radius 3 m about the camera
// (planar depth 3 · ray.z), so that every ray's distance is 3 m.
void write_moge_set(const fs::path& set) {
  const int64_t width = 16, height = 12;
  const omnipoint::camera::Camera camera("PINHOLE", width, height, {12, 12, 8, 6});
  const at::Tensor z = 3.0 * camera.ray_map(at::kFloat).rays.select(-1, 2);
  fs::create_directories(set / "0");
  write_text(set / ".index.txt", "0\n");
  cv::imwrite((set / "0" / "image.jpg").string(), cv::Mat(height, width, CV_8UC3, cv::Scalar(90)));
  omnipoint::data::write_moge_depth((set / "0" / "depth.png").string(), z);
  write_text(set / "0" / "meta.json",
             R"({"intrinsics": [[0.75, 0, 0.5], [0, 1.0, 0.5], [0, 0, 1]]})");
}

// KITTI-360 with DAC's list: an MEI fisheye image_02, one frame whose DAC depth PNG labels a
// block of pixels at 10 m (2560 / 256).
void write_kitti360_set(const fs::path& set, const fs::path& list) {
  const std::string identity = "1 0 0 0 0 1 0 0 0 0 1 0";
  write_text(set / "calibration" / "image_02.yaml",
             "%YAML:1.0\nmodel_type: MEI\ncamera_name: image_02\nimage_width: 64\n"
             "image_height: 64\nmirror_parameters:\n   xi: 1.1\ndistortion_parameters:\n"
             "   k1: 0.02\n   k2: 0.01\n   p1: 0\n   p2: 0\nprojection_parameters:\n"
             "   gamma1: 30\n   gamma2: 30\n   u0: 31.5\n   v0: 31.5\n");
  write_text(set / "calibration" / "calib_cam_to_pose.txt",
             "image_00: " + identity + "\nimage_02: " + identity + "\n");
  write_text(set / "calibration" / "calib_cam_to_velo.txt", identity + "\n");
  const std::string sequence = "2013_05_28_drive_0000_sync";
  const std::string image = "data_2d_raw_subset/" + sequence + "/image_02/data_rgb/0000000010.png";
  const std::string depth = "proj_depth/" + sequence + "/image_02/0000000010.png";
  write_png(set / image, grey_image(64, 64));
  at::Tensor stored = at::zeros({64, 64}, at::kInt);
  stored.narrow(0, 24, 16).narrow(1, 24, 16).fill_(2560);
  write_png(set / depth, stored);
  write_text(list, image + " " + depth + " 30.0000\n");
}

// Stanford2D3D panoramas at 2 m (1024 / 512), the top rows missing (65535).
void write_stanford_panorama(const fs::path& set, const std::string& area,
                             const std::string& name) {
  const std::string stem = "camera_" + name + "_office_1_frame_equirectangular_domain_";
  write_png(set / area / "pano/rgb" / (stem + "rgb.png"), grey_image(kPanoWidth, kPanoHeight));
  at::Tensor stored = at::full({kPanoHeight, kPanoWidth}, 1024, at::kInt);
  stored.narrow(0, 0, 3).fill_(65535);
  write_png(set / area / "pano/depth" / (stem + "depth.png"), stored);
}
std::string stanford_line(const std::string& area, const std::string& name, bool unifuse) {
  const std::string stem = "camera_" + name + "_office_1_frame_equirectangular_domain_";
  return unifuse ? area + "/rgb_/" + stem + "rgb.png " + area + "/depth/" + stem + "depth.png\n"
                 : area + "/pano/rgb/" + stem + "rgb.png " + area + "/pano/depth/" + stem +
                       "depth.png\n";
}

// PanoSUNCG: one panorama, 8-bit depth 115 (115 · 10 / 255 m) in three equal channels.
constexpr double kSuncgDistance = 115.0 * 10.0 / 255.0;
void write_panosuncg_set(const fs::path& set, const fs::path& list) {
  const fs::path folder = set / "rotated" / "0123456789abcdef0123456789abcdef" / "2.txt";
  write_png(folder / "7_color.png", grey_image(kPanoWidth, kPanoHeight));
  write_png(folder / "7_depth.png", at::full({kPanoHeight, kPanoWidth, 3}, 115, at::kByte));
  write_text(list,
             "0123456789abcdef0123456789abcdef/2.txt/7_color.png "
             "0123456789abcdef0123456789abcdef/2.txt/7_depth.png\n");
}

// A data root holding NYUv2, KITTI-360, Stanford2D3D and PanoSUNCG stand-ins, the suite that
// names them (and ETH3D, which is not there), and its lists.
class SuiteRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!omnipoint::io::image_io_available()) return;
    dir_ = new fs::path(omnipoint::test::fresh_process_dir("omnipoint_suite_run"));
    const fs::path data = *dir_ / "data", lists = *dir_ / "suite" / "lists";
    write_moge_set(data / "NYUv2");
    write_kitti360_set(data / "KITTI-360", lists / "kitti360.txt");
    for (const auto& [area, name] : std::vector<std::pair<std::string, std::string>>{
             {"area_5a", "aaaa"}, {"area_5a", "bbbb"}, {"area_1", "cccc"}})
      write_stanford_panorama(data / "Stanford2D3D", area, name);
    write_text(lists / "stanford_da2.txt", stanford_line("area_5a", "aaaa", false) +
                                               stanford_line("area_5a", "bbbb", false) +
                                               stanford_line("area_1", "cccc", false));
    write_text(lists / "stanford_unifuse.txt", stanford_line("area_5a", "bbbb", true));
    write_panosuncg_set(data / "PanoSUNCG", lists / "panosuncg.txt");
    write_text(*dir_ / "suite" / "suite.json", R"({
  "name": "stand-ins",
  "sets": [
    {"name": "NYUv2", "group": "S.FoV", "format": "moge", "root": "NYUv2", "modes": ["none", "+D"]},
    {"name": "ETH3D", "group": "S.FoV", "format": "moge", "root": "ETH3D", "modes": ["none"]},
    {"name": "KITTI-360", "group": "L.FoV", "format": "kitti360", "root": "KITTI-360",
     "split": "lists/kitti360.txt", "options": {"principal_point": "corner"}, "modes": ["none"]},
    {"name": "Stanford2D3D", "group": "360°", "format": "stanford2d3d", "root": "Stanford2D3D",
     "split": "lists/stanford_da2.txt", "modes": ["none"]},
    {"name": "PanoSUNCG", "group": "360°", "format": "panosuncg", "root": "PanoSUNCG",
     "split": "lists/panosuncg.txt", "modes": ["none"]},
    {"name": "Stanford2D3D-UniFuse", "group": "360°", "format": "stanford2d3d",
     "root": "Stanford2D3D", "split": "lists/stanford_unifuse.txt", "modes": ["none"],
     "group_mean": false}
  ]
})");
  }
  static void TearDownTestSuite() {
    if (dir_) fs::remove_all(*dir_);
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (!omnipoint::io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  }
  static std::string suite() { return (*dir_ / "suite" / "suite.json").string(); }
  static std::string data() { return (*dir_ / "data").string(); }
  static omnipoint::eval::EvalJobResult run_job(const std::string& baseline, const std::string& out,
                                                bool sparse = false) {
    omnipoint::eval::EvalJobOptions options;
    options.baseline = baseline;
    options.suite = suite();
    options.suite_root = data();
    options.sparse_depth = sparse;
    options.output_dir = (*dir_ / out).string();
    return omnipoint::eval::EvalJob(options).Run();
  }
  static fs::path* dir_;
};
fs::path* SuiteRun::dir_ = nullptr;

// The oracle (ground-truth rays and distances) scores Rel 0 and δ1 1 in every group and set.
TEST_F(SuiteRun, OracleScoresEveryPresentSetPerfectly) {
  const auto result = run_job("oracle", "oracle", true);
  ASSERT_TRUE(result.suite.has_value());
  const auto& suite = *result.suite;
  ASSERT_EQ(suite.sets.size(), 5u);
  ASSERT_EQ(suite.missing.size(), 1u);
  EXPECT_EQ(suite.missing[0].name, "ETH3D");
  EXPECT_EQ(suite.modes, (std::vector<std::string>{"none", "+D"}));
  const std::map<std::string, int64_t> samples{{"NYUv2", 1},
                                               {"KITTI-360", 1},
                                               {"Stanford2D3D", 3},
                                               {"PanoSUNCG", 1},
                                               {"Stanford2D3D-UniFuse", 1}};
  for (const auto& set : suite.sets) {
    EXPECT_EQ(set.summary.samples_evaluated, samples.at(set.set.name)) << set.set.name;
    EXPECT_EQ(set.summary.skipped.size(), 0u) << set.set.name;
    // +D only where the set lists it.
    EXPECT_EQ(set.summary.modes.size(), set.set.name == "NYUv2" ? 2u : 1u) << set.set.name;
  }
  for (const char* group : {"S.FoV", "L.FoV", "360°"})
    for (const char* entry : {"depth_scale_invariant", "points_scale_invariant", "depth_metric"}) {
      const auto score = omnipoint::eval::group_score(suite, group, "none", entry);
      EXPECT_NEAR(score.rel, 0.0, 1e-5) << group << " " << entry;
      EXPECT_DOUBLE_EQ(score.delta1, 1.0) << group << " " << entry;
    }
  const auto plus_d = omnipoint::eval::group_score(suite, "S.FoV", "+D", "depth_metric");
  EXPECT_DOUBLE_EQ(plus_d.delta1, 1.0);
  EXPECT_EQ(omnipoint::eval::group_score(suite, "360°", "+D", "depth_metric").count, 0);
}

// The constant baseline places 5 m on the true rays: every stand-in's distance is one constant,
// so the scale-invariant entries are exact and the metric ones closed-form; a group is the
// mean of its sets (not of its samples), the UniFuse set outside it.
TEST_F(SuiteRun, ConstantBaselineGivesClosedFormGroupMeans) {
  const fs::path out = *dir_ / "constant";
  const omnipoint::test::CliRun run =
      omnipoint::test::run_omnipoint("eval --baseline constant --suite " + suite() + " --root " +
                                         data() + " --out " + out.string(),
                                     *dir_ / "cli");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("eval: warning: suite set ETH3D not found (" +
                         (fs::path(data()) / "ETH3D").string() + ")\n"),
            std::string::npos)
      << run.err;
  EXPECT_EQ(run.err.find("NYUv2 not found"), std::string::npos) << run.err;

  const json table = json::parse(omnipoint::test::slurp(out / "table.json"));
  EXPECT_EQ(table["suite"], "stand-ins");
  EXPECT_EQ(table["model"], "constant distance 5 m (GT rays)");
  EXPECT_EQ(table["columns"]["depth"], "depth_scale_invariant");
  ASSERT_EQ(table["missing"].size(), 1u);
  EXPECT_EQ(table["missing"][0]["name"], "ETH3D");
  const auto metric = [&](const char* group) { return table["groups"][group]["none"]["metric"]; };
  // |5 - d| / d and whether max(5/d, d/5) < 1.25: 3 m (NYUv2), 10 m (KITTI-360), 2 m
  // (Stanford2D3D), 115·10/255 m (PanoSUNCG).
  EXPECT_NEAR(metric("S.FoV")["rel"].get<double>(), 2.0 / 3.0, 1e-4);
  EXPECT_EQ(metric("S.FoV")["delta1"].get<double>(), 0.0);
  EXPECT_NEAR(metric("L.FoV")["rel"].get<double>(), 0.5, 1e-6);
  EXPECT_EQ(metric("L.FoV")["delta1"].get<double>(), 0.0);
  const double suncg_rel = (kConstant - kSuncgDistance) / kSuncgDistance;
  EXPECT_NEAR(metric("360°")["rel"].get<double>(), (1.5 + suncg_rel) / 2, 1e-5);
  EXPECT_DOUBLE_EQ(metric("360°")["delta1"].get<double>(), 0.5);
  EXPECT_EQ(metric("360°")["count"], 2);  // sets, the UniFuse one left out
  for (const char* group : {"S.FoV", "L.FoV", "360°"})
    for (const char* column : {"depth", "points"}) {
      EXPECT_NEAR(table["groups"][group]["none"][column]["rel"].get<double>(), 0.0, 1e-4)
          << group << " " << column;
      EXPECT_NEAR(table["groups"][group]["none"][column]["delta1"].get<double>(), 1.0, 1e-9)
          << group << " " << column;
    }
  ASSERT_EQ(table["sets"].size(), 5u);
  const json& unifuse = table["sets"][4];
  EXPECT_EQ(unifuse["name"], "Stanford2D3D-UniFuse");
  EXPECT_EQ(unifuse["group_mean"], false);
  EXPECT_EQ(unifuse["samples_evaluated"], 1);
  EXPECT_NEAR(unifuse["scores"]["none"]["metric"]["rel"].get<double>(), 1.5, 1e-6);
  EXPECT_EQ(unifuse["summary"]["datasets"][0], "Stanford2D3D-UniFuse");

  const std::string markdown = omnipoint::test::slurp(out / "table.md");
  EXPECT_EQ(markdown, run.out);
  EXPECT_NE(markdown.find("| Mode | S.FoV depth Rel | S.FoV depth δ1 | S.FoV points Rel | S.FoV "
                          "points δ1 | L.FoV depth Rel | L.FoV depth δ1 | L.FoV points Rel | "
                          "L.FoV points δ1 | 360° depth Rel | 360° depth δ1 | 360° points Rel | "
                          "360° points δ1 |\n"),
            std::string::npos)
      << markdown;
  EXPECT_NE(markdown.find("| none | 0.00 | 100.0 | 0.00 | 100.0 | 0.00 | 100.0 | 0.00 | 100.0 | "
                          "0.00 | 100.0 | 0.00 | 100.0 |\n"),
            std::string::npos)
      << markdown;
  EXPECT_NE(markdown.find("| KITTI-360 | L.FoV | 1 | none | 0.00 | 100.0 | 0.00 | 100.0 | 0.0 |"),
            std::string::npos)
      << markdown;
  EXPECT_NE(markdown.find("| PanoSUNCG | 360° | 1 | none | 0.00 | 100.0 | 0.00 | 100.0 | 100.0 |"),
            std::string::npos)
      << markdown;
  EXPECT_NE(markdown.find("| Stanford2D3D-UniFuse (not in the group mean) | 360° | 1 | none |"),
            std::string::npos)
      << markdown;
  EXPECT_NE(markdown.find("Not found under " + data() + ": ETH3D (ETH3D)"), std::string::npos)
      << markdown;
  // Every scored sample × mode in samples.jsonl, named by its set.
  std::stringstream records(omnipoint::test::slurp(out / "samples.jsonl"));
  std::map<std::string, int> per_set;
  for (std::string line; std::getline(records, line);) ++per_set[json::parse(line)["dataset"]];
  EXPECT_EQ(per_set, (std::map<std::string, int>{{"NYUv2", 1},
                                                 {"KITTI-360", 1},
                                                 {"Stanford2D3D", 3},
                                                 {"PanoSUNCG", 1},
                                                 {"Stanford2D3D-UniFuse", 1}}));
}

// A native format as --data: the same Stanford2D3D stand-in through --format and --split.
TEST_F(SuiteRun, NativeFormatAsData) {
  const fs::path out = *dir_ / "native";
  const omnipoint::test::CliRun run = omnipoint::test::run_omnipoint(
      "eval --baseline constant --format stanford2d3d --data " + data() + "/Stanford2D3D --split " +
          (*dir_ / "suite/lists/stanford_da2.txt").string() + " --option sequence=area_5a --out " +
          out.string(),
      *dir_ / "cli");
  ASSERT_EQ(run.status, 0) << run.err;
  const json summary = json::parse(omnipoint::test::slurp(out / "summary.json"));
  EXPECT_EQ(summary["samples_evaluated"], 2);  // area_5a's two of the list's three
  const json& metric = summary["scores"]["360°"]["none"]["entries"]["depth_metric"];
  EXPECT_NEAR(metric["rel"].get<double>(), 1.5, 1e-6);
  std::stringstream records(omnipoint::test::slurp(out / "samples.jsonl"));
  std::string first;
  std::getline(records, first);
  EXPECT_EQ(json::parse(first)["id"],
            "area_5a/pano/rgb/camera_aaaa_office_1_frame_equirectangular_domain_rgb.png");
}

// Bad suites and options: one error line, exit 1, nothing written.
TEST_F(SuiteRun, BadInputGivesOneErrorLine) {
  const fs::path bad = *dir_ / "bad_suite.json";
  write_text(bad, R"({"name": "s", "sets": [{"name": "A", "group": "wide"}]})");
  const auto expect_error = [&](const std::string& args, const std::string& needle) {
    const fs::path out = *dir_ / "bad_out";
    const omnipoint::test::CliRun run = omnipoint::test::run_omnipoint(
        "eval --baseline oracle " + args + " --out " + out.string(), *dir_ / "cli");
    EXPECT_EQ(run.status, 1) << args;
    EXPECT_EQ(run.err.find('\n'), run.err.size() - 1) << run.err;
    EXPECT_EQ(run.err.rfind("omnipoint: error: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find(needle), std::string::npos) << run.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  };
  expect_error("--suite " + bad.string() + " --root " + data(),
               bad.string() + ": sets[0].group: expected \"S.FoV\", \"L.FoV\" or \"360°\"");
  write_text(bad, "{\"name\": ");
  expect_error("--suite " + bad.string() + " --root " + data(), bad.string() + ": not JSON");
  expect_error("--suite " + suite(), "--suite needs --root");
  expect_error("--suite " + suite() + " --root " + data() + " --data " + data(),
               "give either --data (datasets) or --suite");
  expect_error("--suite " + suite() + " --root " + (*dir_ / "nowhere").string(),
               "data root " + (*dir_ / "nowhere").string() + ": not a folder");
  expect_error("--suite " + suite() + " --root " + (*dir_ / "suite").string(),
               "holds none of the suite's 6 sets");
  expect_error("--data " + data() + " --split x.txt", "--split and --option need --format");
  expect_error("--format nope --data " + data(), "dataset format \"nope\": unknown");
  expect_error("--format stanford2d3d --option sequence --data " + data(),
               "--option sequence: expected NAME=VALUE");
  // A set that is there but does not open stops the run before anything is scored.
  write_text(bad, R"({"name": "s", "sets": [{"name": "S", "group": "360°",
      "format": "stanford2d3d", "root": "PanoSUNCG", "modes": ["none"]}]})");
  expect_error("--suite " + bad.string() + " --root " + data(), "suite set S: dataset");
}

#endif  // OMNIPOINT_WITH_OPENCV

}  // namespace
