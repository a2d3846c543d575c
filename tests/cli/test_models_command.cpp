// Published models by name, end to end: `omnipoint predict photo.png --model hf:...` with
// HF_ENDPOINT at a stand-in hub on 127.0.0.1 (support/hub_server.h) serving a small MoGe-2
// checkpoint gives what the local file gives; `models pull` and `models list`; `forward` takes
// a short name too; and each fault (no network, 401, 404, a wrong checksum, offline without a
// copy) is one error line with nothing landed in the cache.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "support/cli_run.h"
#include "support/hub_server.h"
#include "support/scratch_dir.h"

namespace omnipoint {
namespace {

namespace fs = std::filesystem;

const std::string kRepo = "Ruicheng/moge-2-vitl-normal";
const std::string kFixtureModel =
    std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/model.safetensors";

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

class ModelsCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_process_dir(
        "omnipoint_models_" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    server_.add(kRepo, "model.safetensors", io::read_file(kFixtureModel));
    if (io::image_io_available())
      io::write_image_png((dir_ / "photo.png").string(), at::rand({42, 56, 3}));
  }
  void TearDown() override { fs::remove_all(dir_); }

  // `omnipoint ARGS` in dir_, against the stand-in hub (or `endpoint`) with the cache in
  // dir_/cache; `environment`: more "NAME=value " assignments.
  test::CliRun run(const std::string& args, const std::string& environment = "",
                   const std::string& endpoint = "") const {
    return test::run_command(
        "cd '" + dir_.string() + "' && env -u HF_TOKEN -u HF_HUB_OFFLINE -u OMNIPOINT_MODEL " +
            "no_proxy=127.0.0.1 HF_ENDPOINT=" + (endpoint.empty() ? server_.endpoint() : endpoint) +
            " OMNIPOINT_CACHE='" + (dir_ / "cache").string() + "' " + environment + "'" +
            OMNIPOINT_CLI + "' " + args,
        dir_ / "run");
  }
  // The run failed with exactly one error line, the last, containing `part`, and the cache
  // holds no finished file.
  void expect_one_error_line(const test::CliRun& result, const std::string& part) const {
    EXPECT_NE(result.status, 0);
    const std::vector<std::string> err = lines(result.err);
    int errors = 0;
    for (const std::string& line : err) errors += line.rfind("omnipoint: error: ", 0) == 0;
    EXPECT_EQ(errors, 1) << result.err;
    ASSERT_FALSE(err.empty());
    EXPECT_EQ(err.back().rfind("omnipoint: error: ", 0), 0u) << result.err;
    EXPECT_NE(err.back().find(part), std::string::npos) << result.err;
    if (!fs::exists(dir_ / "cache")) return;
    for (const auto& entry : fs::recursive_directory_iterator(dir_ / "cache")) {
      if (entry.is_directory()) continue;
      EXPECT_NE(entry.path().string().find(".incomplete"), std::string::npos) << entry.path();
    }
  }

  test::HubServer server_;
  fs::path dir_;
};

TEST_F(ModelsCommand, PredictFetchesTheModelByNameAndPredictsAsWithTheFile) {
  if (!io::image_io_available()) GTEST_SKIP() << "built without image I/O";
  const test::CliRun fetched = run("predict photo.png --model hf:" + kRepo +
                                   " --out by_name --outputs npy --num-tokens 300");
  ASSERT_EQ(fetched.status, 0) << fetched.err;
  EXPECT_NE(fetched.err.find("omnipoint: downloading hf:" + kRepo + "/model.safetensors (2.25 MB)"),
            std::string::npos)
      << fetched.err;
  // No progress bar or note about the bundled model in a log.
  EXPECT_EQ(fetched.err.find('\r'), std::string::npos);
  EXPECT_EQ(fetched.err.find("bundled model"), std::string::npos) << fetched.err;
  const test::CliRun local = run("predict photo.png --model '" + kFixtureModel +
                                 "' --out by_file --outputs npy --num-tokens 300");
  ASSERT_EQ(local.status, 0) << local.err;
  for (const char* map : {"points.npy", "rays.npy", "distance.npy"})
    EXPECT_EQ(test::slurp(dir_ / "by_name" / "photo" / map),
              test::slurp(dir_ / "by_file" / "photo" / map))
        << map;
  // Again: from the cache (one HEAD request), no download.
  server_.clear_requests();
  const test::CliRun again = run(
      "predict photo.png --model moge-2-vitl-normal --out again --outputs npy --num-tokens 300");
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_EQ(again.err.find("downloading"), std::string::npos) << again.err;
  EXPECT_EQ(server_.requests().size(), 2u);  // the model API and the HEAD
  EXPECT_EQ(test::slurp(dir_ / "again" / "photo" / "points.npy"),
            test::slurp(dir_ / "by_file" / "photo" / "points.npy"));
}

TEST_F(ModelsCommand, PullPrintsThePathAndListShowsTheCache) {
  const test::CliRun empty = run("models list");
  EXPECT_EQ(empty.status, 0) << empty.err;
  EXPECT_EQ(empty.out, "");
  EXPECT_NE(empty.err.find("holds no model"), std::string::npos) << empty.err;

  const test::CliRun pull = run("models pull moge-2-vitl-normal");
  ASSERT_EQ(pull.status, 0) << pull.err;
  const std::string commit = test::HubServer::commit_of(kRepo);
  const fs::path path = dir_ / "cache" / "hub" / "models--Ruicheng--moge-2-vitl-normal" /
                        "snapshots" / commit / "model.safetensors";
  EXPECT_EQ(pull.out,
            "hf:" + kRepo + "/model.safetensors -> " + path.string() + " (2.25 MB, downloaded)\n");
  EXPECT_EQ(io::read_file(path.string()), io::read_file(kFixtureModel));
  const test::CliRun again = run("models pull hf:" + kRepo + "/model.safetensors");
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_NE(again.out.find("(2.25 MB, already cached)"), std::string::npos) << again.out;

  const test::CliRun list = run("models list");
  ASSERT_EQ(list.status, 0) << list.err;
  EXPECT_EQ(list.out, "hf:" + kRepo + "/model.safetensors  2.25 MB  commit " +
                          commit.substr(0, 12) + "  " + path.string() + "\n");
}

TEST_F(ModelsCommand, ForwardTakesAShortName) {
  io::write_npy((dir_ / "image.npy").string(), at::rand({1, 3, 28, 42}));
  const test::CliRun by_name =
      run("forward --model moge-2-vitl-normal --input image.npy --out by_name --num-tokens 300");
  ASSERT_EQ(by_name.status, 0) << by_name.err;
  const test::CliRun by_file = run("forward --model '" + kFixtureModel +
                                   "' --input image.npy --out by_file --num-tokens 300");
  ASSERT_EQ(by_file.status, 0) << by_file.err;
  EXPECT_EQ(test::slurp(dir_ / "by_name" / "points.npy"),
            test::slurp(dir_ / "by_file" / "points.npy"));
}

TEST_F(ModelsCommand, EachFaultIsOneLineAndLandsNothing) {
  // No network: nothing listens on the discard port.
  expect_one_error_line(run("models pull moge-2-vitl-normal", "", "http://127.0.0.1:9"),
                        "cannot reach the hub");
  // 404, naming the URL.
  expect_one_error_line(
      run("models pull hf:" + kRepo + "/missing.pt"),
      "not found (HTTP 404): " + server_.endpoint() + "/" + kRepo + "/resolve/main/missing.pt");
  // Offline without a copy.
  expect_one_error_line(run("models pull moge-2-vitl-normal", "HF_HUB_OFFLINE=1 "),
                        "HF_HUB_OFFLINE is set");
  // A wrong checksum (after the "downloading" line).
  server_.corrupt_checksum(kRepo, "model.safetensors");
  expect_one_error_line(run("models pull moge-2-vitl-normal"), "checksum mismatch");
  // Gated: 401 without a token.
  server_.gate(kRepo, "secret");
  expect_one_error_line(run("models pull moge-2-vitl-normal"), "access denied (HTTP 401)");
  if (io::image_io_available()) {  // the same through predict, with no output folder left
    expect_one_error_line(run("predict photo.png --model moge-2-vitl-normal --out out"),
                          "HF_TOKEN");
    EXPECT_FALSE(fs::exists(dir_ / "out"));
  }
}

}  // namespace
}  // namespace omnipoint
