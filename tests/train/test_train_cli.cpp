// `omnipoint train` end to end: the command binds a training session (the session itself is
// tested through the library, test_training_session.cpp) and launches data-parallel ranks.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "omnipoint/io/image.h"
#include "omnipoint/io/safetensors.h"
#include "support/cli_run.h"
#include "train/tiny_training.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

int run_cli(const std::string& arguments) {
  return std::system((std::string(OMNIPOINT_CLI) + " train " + arguments + " 2>/dev/null").c_str());
}

// Stopped, resumed to the end, its curves redrawn: exit codes, the progress lines and the
// files; a checkpoint that is not there is one error line.
TEST(TrainCli, TrainsStopsResumesAndRedrawsCurves) {
  const std::string root = temp_dir("cli");
  json config = tiny_config(root + "/run");
  config["log_every"] = 2;
  const std::string path = root + "/run.json";
  std::ofstream(path) << config.dump(2);
  const fs::path scratch = fs::path(root) / "scratch";

  const test::CliRun stopped =
      test::run_omnipoint("train --config " + path + " --stop-after 3", scratch);
  ASSERT_EQ(stopped.status, 0) << stopped.err;
  EXPECT_NE(stopped.err.find("train: step 2/5 (stage 1) loss "), std::string::npos) << stopped.err;
  EXPECT_NE(stopped.err.find("train: step 3/5 (stage 2) loss "), std::string::npos) << stopped.err;
  EXPECT_NE(stopped.err.find(" img/s  ETA "), std::string::npos) << stopped.err;
  EXPECT_EQ(stopped.err.find("train: done"), std::string::npos) << stopped.err;
  EXPECT_FALSE(fs::exists(root + "/run/model.safetensors"));

  const test::CliRun resumed =
      test::run_omnipoint("train --config " + path + " --resume " + root + "/run", scratch);
  ASSERT_EQ(resumed.status, 0) << resumed.err;
  EXPECT_NE(resumed.err.find("train: step 5/5 (stage 3) loss "), std::string::npos) << resumed.err;
  EXPECT_NE(resumed.err.find("train: done; weights in " + root + "/run/model.safetensors"),
            std::string::npos)
      << resumed.err;
  EXPECT_EQ(losses_by_step(root + "/run/log.jsonl").size(), 5u);
  EXPECT_EQ(io::read_safetensors(root + "/run/model_ema.safetensors", std::nullopt).tensors.size(),
            io::read_safetensors(root + "/run/model.safetensors", std::nullopt).tensors.size());

  if (io::image_io_available()) {
    fs::remove(root + "/run/curves.png");
    ASSERT_EQ(test::run_omnipoint("train --config " + path + " --curves-only", scratch).status, 0);
    EXPECT_TRUE(fs::exists(root + "/run/curves.png"));
  }
  const test::CliRun missing =
      test::run_omnipoint("train --config " + path + " --resume " + root + "/nothing", scratch);
  EXPECT_NE(missing.status, 0);
  EXPECT_EQ(missing.err.rfind("omnipoint: error: ", 0), 0u) << missing.err;
  fs::remove_all(root);
}

TEST(TrainCli, TwoGlooRanksEqualOneProcessOnTheCombinedBatch) {
  const std::string root = temp_dir("ddp");
  const auto write_config = [&](const std::string& name, int64_t batch_size) {
    json config = tiny_config(root + "/" + name);
    config["data"]["batch_size"] = batch_size;
    // The local loss draws its anchors per process; off here so that the objective is the same.
    config["loss"]["weights"] = {{"local", 0}};
    // The all-reduce sums in another order than autograd over the whole batch (float rounding,
    // ~1e-7 relative). With Adam's eps ~ 0 the first update is lr·sign(g), which turns that
    // rounding into ±lr for the gradients that are ~0; eps = 1 keeps the update proportional to
    // the gradient, so the comparison measures the gradients the ranks agree on.
    config["optimizer"] = {{"eps", 1.0}};
    const std::string path = root + "/" + name + ".json";
    std::ofstream(path) << config.dump(2);
    return path;
  };
  const std::string single = write_config("single", 2), ranks = write_config("ranks", 1);
  ASSERT_EQ(run_cli("--config " + single), 0);
  const std::string port = std::to_string(20000 + ::getpid() % 20000);
  ASSERT_EQ(std::system(("MASTER_PORT=" + port + " " + std::string(OMNIPOINT_CLI) +
                         " train --config " + ranks + " --nproc 2 2>/dev/null")
                            .c_str()),
            0);
  const auto a = io::read_safetensors(root + "/single/model.safetensors", std::nullopt).tensors;
  const auto b = io::read_safetensors(root + "/ranks/model.safetensors", std::nullopt).tensors;
  ASSERT_EQ(a.size(), b.size());
  double worst = 0;
  for (const auto& [name, t] : a)
    worst = std::max(worst, (t - b.at(name)).abs().max().item<double>());
  EXPECT_LE(worst, 1e-6);
  // Only rank 0 wrote the log: one record per step.
  EXPECT_EQ(losses_by_step(root + "/ranks/log.jsonl").size(), 5u);
  fs::remove_all(root);
}

}  // namespace
}  // namespace omnipoint::train
