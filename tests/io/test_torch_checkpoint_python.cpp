// PyTorch checkpoints written by PyTorch itself (tests/tools/make_torch_checkpoints.py, Debian's
// python3-torch; skipped without it), read by the C++ reader: MoGe-2's model.pt gives the points
// of its converted .safetensors, every dtype and layout reads back bit for bit, DINOv2's hub
// weights initialise an encoder, and what Python's pickle would run is refused with one line.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include "omnipoint/infer/infer.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/io/torch_checkpoint.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/state_dict.h"
#include "support/cli_run.h"
#include "support/expect_error.h"
#include "support/scratch_dir.h"

namespace fs = std::filesystem;
using omnipoint::test::expect_error;

namespace {

const std::string kFixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a";
constexpr int kSkip = 77;  // make_torch_checkpoints.py: no torch

// One Python process writes every checkpoint once for the whole suite (PyTorch takes seconds
// to import).
class TorchCheckpointPython : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(omnipoint::test::fresh_process_dir("omnipoint_torch_python"));
    const std::string command = "/usr/bin/python3 " + std::string(OMNIPOINT_SOURCE_DIR) +
                                "/tests/tools/make_torch_checkpoints.py " + dir_->string() + " " +
                                kFixture + "/model.safetensors >" + (*dir_ / "log").string() +
                                " 2>&1";
    const int status = std::system(command.c_str());
    status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  void SetUp() override {
    if (status_ == kSkip)
      GTEST_SKIP() << "/usr/bin/python3 lacks torch (apt-get install python3-torch)";
    ASSERT_EQ(status_, 0) << omnipoint::test::slurp(*dir_ / "log");
  }
  static std::string path(const std::string& name) { return (*dir_ / name).string(); }

  static fs::path* dir_;
  static int status_;
};
fs::path* TorchCheckpointPython::dir_ = nullptr;
int TorchCheckpointPython::status_ = 0;

at::Tensor points_of(const std::string& model, const at::Tensor& image) {
  return omnipoint::infer::forward(omnipoint::infer::load_network(model), image, 300).points;
}

}  // namespace

TEST_F(TorchCheckpointPython, MoGe2ModelPtGivesTheConvertedSafetensorsPoints) {
  const at::Tensor image = omnipoint::io::read_npy(kFixture + "/input.npy");
  const at::Tensor converted = points_of(path("moge2_converted.safetensors"), image);
  const at::Tensor fixture = points_of(kFixture + "/model.safetensors", image);
  for (const char* file : {"moge2.pt", "moge2_p4.pt"}) {
    SCOPED_TRACE(file);
    const at::Tensor points = points_of(path(file), image);
    ASSERT_EQ(points.sizes(), converted.sizes());
    EXPECT_LE((points - converted).abs().max().item<double>(), 1e-6);
    EXPECT_LE((points - fixture).abs().max().item<double>(), 1e-6);
  }
}

TEST_F(TorchCheckpointPython, TheToolTakesTheModelPtDirectly) {
  const fs::path out = *dir_ / "forward_out";
  const omnipoint::test::CliRun result = omnipoint::test::run_omnipoint(
      "forward --model " + path("moge2.pt") + " --input " + kFixture +
          "/input.npy --num-tokens 300 --precision fp32 --out " + out.string(),
      *dir_ / "cli");
  ASSERT_EQ(result.status, 0) << result.err;
  const at::Tensor image = omnipoint::io::read_npy(kFixture + "/input.npy");
  EXPECT_TRUE(at::equal(omnipoint::io::read_npy((out / "points.npy").string()),
                        points_of(path("moge2_converted.safetensors"), image)));
}

TEST_F(TorchCheckpointPython, StrictLoadingReportsMissingUnexpectedAndMisshapedKeys) {
  std::istringstream names(omnipoint::test::slurp(*dir_ / "bad_keys.txt"));
  std::string missing, misshaped;
  names >> missing >> misshaped;
  expect_error<std::runtime_error>(
      [&] { omnipoint::infer::load_network(path("moge2_bad_keys.pt")); },
      {path("moge2_bad_keys.pt"), "weights do not match the model", "1 missing (" + missing + ")",
       "1 unexpected (extra.weight)", "1 mismatched (" + misshaped + ": given [3, 3, 3]"});
}

TEST_F(TorchCheckpointPython, EveryDtypeStrideOffsetAndSharedStorage) {
  const omnipoint::io::WeightsFile read =
      omnipoint::io::read_weights(path("tensors.pt"), std::nullopt);
  const omnipoint::io::SafetensorsFile expected =
      omnipoint::io::read_safetensors(path("tensors.safetensors"), std::nullopt);
  ASSERT_EQ(read.tensors.size(), expected.tensors.size());
  ASSERT_EQ(read.tensors.size(), 17u);
  for (const auto& [name, tensor] : expected.tensors) {
    SCOPED_TRACE(name);
    ASSERT_EQ(read.tensors.count(name), 1u);
    EXPECT_EQ(read.tensors.at(name).scalar_type(), tensor.scalar_type());
    EXPECT_TRUE(at::equal(read.tensors.at(name), tensor));
  }
  // The object itself: an OrderedDict in Python's order, views of one storage where Python
  // had them.
  const omnipoint::io::PickleValue root = omnipoint::io::read_torch_checkpoint(path("tensors.pt"));
  EXPECT_EQ(root.keys().front().as_string(), "torch.float32");
  const at::Tensor a = root.find("shared_a")->as_tensor(), b = root.find("shared_b")->as_tensor();
  EXPECT_EQ(static_cast<const char*>(b.data_ptr()) - static_cast<const char*>(a.data_ptr()), 5 * 4);
  EXPECT_FALSE(root.find("transposed")->as_tensor().is_contiguous());
  EXPECT_EQ(root.find("offset_slice")->as_tensor().storage_offset(), 11);
}

TEST_F(TorchCheckpointPython, DinoV2HubWeightsInitialiseTheEncoder) {
  const omnipoint::io::SafetensorsFile source =
      omnipoint::io::read_safetensors(kFixture + "/model.safetensors");
  const omnipoint::model::MoGe2Config moge2 =
      omnipoint::model::MoGe2Config::from_json_text(source.metadata.at("config"));
  omnipoint::model::OmniPointModel model(omnipoint::model::OmniPointConfig::from_moge2(
      moge2, omnipoint::model::OutputKind::kRayDistance));
  const omnipoint::io::WeightsFile hub = omnipoint::io::read_weights(path("dinov2.pth"));
  EXPECT_EQ(hub.metadata.at("format"), "state_dict");
  const omnipoint::model::InitReport report =
      omnipoint::model::init_from_dinov2(*model, hub.tensors);
  EXPECT_EQ(report.loaded.size(), hub.tensors.size());
  const auto loaded = omnipoint::model::state_dict(*model);
  for (const auto& [name, tensor] : hub.tensors)
    EXPECT_TRUE(at::equal(loaded.at("encoder.backbone." + name), tensor)) << name;
  // Not a model to run on its own: one line saying what it is for.
  expect_error<std::invalid_argument>(
      [&] { omnipoint::infer::load_network(path("dinov2.pth")); },
      {path("dinov2.pth"), "a bare state dict", "init.from \"dinov2\""});
}

TEST_F(TorchCheckpointPython, WhatPythonsPickleWouldRunIsRefused) {
  expect_error<std::runtime_error>(
      [&] { omnipoint::io::read_weights(path("os_system.pt")); },
      {path("os_system.pt"), "refuses the pickled global 'posix.system'"});
  expect_error<std::runtime_error>(
      [&] { omnipoint::infer::load_network(path("eval.pt")); },
      {path("eval.pt"), "refuses the pickled global '__builtin__.eval'"});
  EXPECT_FALSE(fs::exists(path("pwned")));
}

TEST_F(TorchCheckpointPython, UnsupportedContentFailsWithOneLine) {
  expect_error<std::runtime_error>(
      [&] { omnipoint::io::read_weights(path("complex.pt")); },
      {path("complex.pt"), "torch.ComplexFloatStorage is not supported"});
  expect_error<std::runtime_error>([&] { omnipoint::io::read_weights(path("legacy.pt")); },
                                   {path("legacy.pt"), "pre-1.6 format", "re-save"});
  expect_error<std::runtime_error>([&] { omnipoint::io::read_weights(path("list.pt")); },
                                   {path("list.pt"), "holds a list"});
}
