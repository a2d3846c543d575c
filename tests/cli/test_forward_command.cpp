// End to end: `omnipoint forward` on the MoGe-2 fixture, and its refusals of bad inputs.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "omnipoint/io/npy.h"
#include "support/cli_run.h"

namespace {

namespace fs = std::filesystem;
using omnipoint::io::read_npy;

const std::string kFixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a";
const std::string kModel = kFixture + "/model.safetensors";

class ForwardCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("omnipoint_forward_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  omnipoint::test::CliRun run(const std::string& arguments) const {
    return omnipoint::test::run_omnipoint("forward " + arguments, dir_ / "cli");
  }

  // A failed run: non-zero exit, exactly one line naming `mention`, no output folder content.
  void expect_refusal(const std::string& arguments, const std::string& mention) const {
    const omnipoint::test::CliRun result = run(arguments + " --out " + (dir_ / "out").string());
    EXPECT_NE(result.status, 0) << arguments;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_EQ(result.err.rfind("omnipoint: error: ", 0), 0u) << result.err;
    EXPECT_NE(result.err.find(mention), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(dir_ / "out" / "points.npy"));
  }

  fs::path dir_;
};

void expect_close(const at::Tensor& actual, const at::Tensor& reference, const std::string& name) {
  ASSERT_EQ(actual.sizes(), reference.sizes()) << name;
  const at::Tensor excess = (actual - reference).abs() - (1e-4 + 1e-4 * reference.abs());
  EXPECT_LE(excess.max().item<float>(), 0.0f) << name;
}

TEST_F(ForwardCommand, WritesTheFixtureOutputs) {
  const fs::path out = dir_ / "out";
  const omnipoint::test::CliRun result =
      run("--model " + kModel + " --input " + kFixture +
          "/input.npy --num-tokens 300 --precision fp32 --out " + out.string());
  ASSERT_EQ(result.status, 0) << result.err;
  EXPECT_EQ(result.err, "");
  const at::Tensor points = read_npy((out / "points.npy").string());
  expect_close(points, read_npy(kFixture + "/expected_points.npy"), "points");
  expect_close(read_npy((out / "mask.npy").string()), read_npy(kFixture + "/expected_mask.npy"),
               "mask");
  expect_close(read_npy((out / "metric_scale.npy").string()),
               read_npy(kFixture + "/expected_metric_scale.npy"), "metric_scale");
  // Rays and distances describe the same point map.
  const at::Tensor rays = read_npy((out / "rays.npy").string());
  const at::Tensor distance = read_npy((out / "distance.npy").string());
  EXPECT_TRUE(
      at::allclose(at::linalg_vector_norm(rays, 2, {-1}), at::ones_like(distance), 0, 1e-5));
  EXPECT_TRUE(at::allclose(rays * distance.unsqueeze(-1), points, 1e-5, 1e-5));
  EXPECT_FALSE(fs::exists(out / "normal.npy"));  // the fixture model has no normal head
}

TEST_F(ForwardCommand, RefusesBadFilesWithOneLine) {
  const std::string input = kFixture + "/input.npy";
  expect_refusal("--model " + (dir_ / "missing.safetensors").string() + " --input " + input,
                 "missing.safetensors");
  expect_refusal("--model " + input + " --input " + input, input);  // not a weights file
  expect_refusal("--model " + kModel + " --input " + (dir_ / "missing.npy").string(),
                 "missing.npy");
}

TEST_F(ForwardCommand, RefusesBadImageArraysWithOneLine) {
  const std::string input = kFixture + "/input.npy";
  expect_refusal("--model " + kModel + " --input " + kFixture + "/expected_points.npy",
                 "(B,3,H,W)");
  expect_refusal("--model " + kModel + " --input " + input + " --num-tokens 0", "--num-tokens");

  const std::string too_bright = (dir_ / "too_bright.npy").string();
  omnipoint::io::write_npy(too_bright, read_npy(input) * 2);
  expect_refusal("--model " + kModel + " --input " + too_bright, "[0,1]");
  const std::string integers = (dir_ / "integers.npy").string();
  omnipoint::io::write_npy(integers, at::zeros({1, 3, 8, 8}, at::kByte));
  expect_refusal("--model " + kModel + " --input " + integers, "float32");
}

TEST_F(ForwardCommand, RefusesPrecisionsItCannotRun) {
  const std::string arguments = "--model " + kModel + " --input " + kFixture + "/input.npy";
  expect_refusal(arguments + " --precision fp8",
                 "--precision fp8: expected auto, fp32, bf16 or fp16");
  expect_refusal(arguments + " --precision fp16", "--precision fp16 needs --device cuda");
}

}  // namespace

TEST_F(ForwardCommand, RunsAnOmniPointCheckpoint) {
  const fs::path model = dir_ / "tiny.safetensors";
  ASSERT_EQ(omnipoint::test::run_omnipoint(
                "init-model --config " + std::string(OMNIPOINT_SOURCE_DIR) +
                    "/examples/models/tiny_omnipoint.json --out " + model.string() + " --seed 3",
                dir_ / "cli")
                .status,
            0);
  const fs::path out = dir_ / "out";
  const omnipoint::test::CliRun result = run("--model " + model.string() + " --input " + kFixture +
                                             "/input.npy --out " + out.string());
  ASSERT_EQ(result.status, 0) << result.err;
  EXPECT_FALSE(fs::exists(out / "normal.npy")) << "the OmniPoint model has no normal head";

  const at::Tensor image = read_npy(kFixture + "/input.npy");
  const int64_t batch = image.size(0), height = image.size(2), width = image.size(3);
  const at::Tensor rays = read_npy((out / "rays.npy").string());
  const at::Tensor distance = read_npy((out / "distance.npy").string());
  const at::Tensor scale = read_npy((out / "metric_scale.npy").string());
  const at::Tensor points = read_npy((out / "points.npy").string());
  const at::Tensor mask = read_npy((out / "mask.npy").string());
  ASSERT_EQ(rays.sizes(), (std::vector<int64_t>{batch, height, width, 3}));
  ASSERT_EQ(distance.sizes(), (std::vector<int64_t>{batch, height, width}));
  ASSERT_EQ(mask.sizes(), (std::vector<int64_t>{batch, height, width}));
  ASSERT_EQ(scale.sizes(), (std::vector<int64_t>{batch}));
  EXPECT_LE((rays.norm(2, -1) - 1).abs().max().item<float>(), 1e-5f);
  EXPECT_GT(distance.min().item<float>(), 0.0f);
  EXPECT_GE(mask.min().item<float>(), 0.0f);
  EXPECT_LE(mask.max().item<float>(), 1.0f);
  expect_close(points, scale.view({batch, 1, 1, 1}) * distance.unsqueeze(-1) * rays,
               "points = s·d·r");
}
