// tools/convert_checkpoint.py, end to end: tiny checkpoints saved by PyTorch, converted, and
// read back here bit for bit. Needs Debian's python3-torch (skipped without it). PyTorch takes
// seconds to import, so one Python process makes the checkpoints and runs the conversions
// (through the tool's main()), and the command line itself runs once.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/safetensors.h"

namespace fs = std::filesystem;
using omnipoint::io::read_safetensors;
using omnipoint::io::SafetensorsFile;

namespace {

const std::string kPython = "/usr/bin/python3";
const std::string kTool = std::string(OMNIPOINT_SOURCE_DIR) + "/tools/convert_checkpoint.py";
constexpr int kSkip = 77;  // make_checkpoints.py: no torch/numpy

int run(const std::string& command) {
  const int status = std::system((command + " >/dev/null 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The dtype each tensor of make_checkpoints.py has in its checkpoint.
const std::map<std::string, at::ScalarType> kStored = {{"blocks.0.attn.qkv.weight", at::kFloat},
                                                       {"blocks.0.ls1.gamma", at::kFloat},
                                                       {"norm.bias", at::kDouble},
                                                       {"patch_embed.proj.weight", at::kHalf},
                                                       {"pos_embed", at::kBFloat16},
                                                       {"steps", at::kLong},
                                                       {"valid", at::kBool},
                                                       {"scalar", at::kFloat},
                                                       {"transposed", at::kFloat}};

class Workspace {
 public:
  Workspace()
      : dir_(fs::temp_directory_path() / ("omnipoint_convert_" + std::to_string(::getpid()))) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  ~Workspace() { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  const fs::path& dir() const { return dir_; }

  // Every tensor of the checkpoint, named `prefix + name`, holds the expected values, in
  // `floats` if given (else in its checkpoint dtype), bit for bit.
  void expect_tensors(const std::string& file_name, const std::string& prefix,
                      std::optional<at::ScalarType> floats) const {
    SCOPED_TRACE(file_name);
    const SafetensorsFile file = read_safetensors(path(file_name), std::nullopt);
    ASSERT_EQ(file.tensors.size(), kStored.size());
    for (const auto& [name, type] : kStored) {
      const auto it = file.tensors.find(prefix + name);
      ASSERT_NE(it, file.tensors.end()) << prefix + name;
      const at::ScalarType want = (floats && at::isFloatingType(type)) ? *floats : type;
      const at::Tensor reference = expected(name).to(type).to(want);
      EXPECT_EQ(it->second.scalar_type(), want) << name;
      EXPECT_EQ(it->second.sizes(), reference.sizes()) << name;
      EXPECT_TRUE(at::equal(it->second, reference)) << name;
    }
  }
  at::Tensor expected(const std::string& name) const {
    return omnipoint::io::read_npy(path(name + ".npy"));
  }

 private:
  fs::path dir_;
};

}  // namespace

TEST(ConvertCheckpoint, LayoutsPrefixesDtypesAndErrors) {
  const Workspace ws;
  const std::vector<std::string> jobs = {
      "moge2.pt moge2.safetensors",
      "moge2.pt f16.safetensors --dtype f16",
      "moge2.pt bf16.safetensors --dtype bf16",
      "bare.pt bare.safetensors --strip-prefix module. --add-prefix encoder.backbone.",
      "bare.pt f32.safetensors --dtype f32 --add-prefix x.",
      "list.pt list.safetensors",
      "bare.pt strip.safetensors --strip-prefix blocks.",
      "missing.pt missing.safetensors",
  };
  std::string command = kPython + " " + OMNIPOINT_SOURCE_DIR + "/tests/tools/make_checkpoints.py " +
                        ws.dir().string();
  for (const std::string& job : jobs) command += " '" + job + "'";
  const int made = run(command);
  if (made == kSkip)
    GTEST_SKIP() << kPython << " lacks torch/numpy (apt-get install python3-torch python3-numpy)";
  ASSERT_EQ(made, 0) << command;
  std::vector<int> statuses;
  std::istringstream lines(omnipoint::io::read_file(ws.path("status.txt")));
  for (int status; lines >> status;) statuses.push_back(status);
  EXPECT_EQ(statuses, (std::vector<int>{0, 0, 0, 0, 0, 1, 1, 1}));

  // MoGe-2 layout: dtypes kept, config as the JSON string Python wrote.
  ws.expect_tensors("moge2.safetensors", "", std::nullopt);
  const SafetensorsFile moge2 = read_safetensors(ws.path("moge2.safetensors"), std::nullopt);
  EXPECT_EQ(moge2.metadata.size(), 2u);
  EXPECT_EQ(moge2.metadata.at("format"), "moge2");
  EXPECT_EQ(moge2.metadata.at("config"), omnipoint::io::read_file(ws.path("config.txt")));
  EXPECT_EQ(nlohmann::json::parse(moge2.metadata.at("config"))["name"], "tïny \"model\"");
  // The Python writer and ours produce the same bytes.
  EXPECT_EQ(omnipoint::io::encode_safetensors(moge2.tensors, moge2.metadata),
            omnipoint::io::read_file(ws.path("moge2.safetensors")));

  // Half and bfloat16 storage; reading converts to float32 by default.
  ws.expect_tensors("f16.safetensors", "", at::kHalf);
  ws.expect_tensors("bf16.safetensors", "", at::kBFloat16);
  EXPECT_TRUE(at::equal(read_safetensors(ws.path("bf16.safetensors")).tensors.at("pos_embed"),
                        ws.expected("pos_embed")));

  // Bare state_dict, prefixes stripped and added.
  ws.expect_tensors("bare.safetensors", "encoder.backbone.", std::nullopt);
  EXPECT_EQ(read_safetensors(ws.path("bare.safetensors")).metadata,
            (std::map<std::string, std::string>{{"format", "state_dict"}}));
  ws.expect_tensors("f32.safetensors", "x.module.", at::kFloat);

  // Failures leave no output and no temporary file.
  EXPECT_FALSE(fs::exists(ws.path("list.safetensors")));
  EXPECT_FALSE(fs::exists(ws.path("strip.safetensors")));
  for (const auto& entry : fs::directory_iterator(ws.dir())) {
    EXPECT_NE(entry.path().filename().string()[0], '.') << "temporary file left: " << entry.path();
  }

  // The command line itself.
  EXPECT_EQ(run(kPython + " " + kTool + " " + ws.path("moge2.pt") + " " +
                ws.path("cli.safetensors") + " --dtype f16"),
            0);
  ws.expect_tensors("cli.safetensors", "", at::kHalf);
}
