// End to end: a command line whose command is mistyped or missing gets one line naming the
// word and the command it was likely meant to be (or the commands there are), and a non-zero
// exit; the commands themselves still parse.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "support/cli_run.h"
#include "support/scratch_dir.h"

namespace {

using omnipoint::test::CliRun;

CliRun run(const std::string& arguments) {
  static const std::filesystem::path scratch =
      omnipoint::test::fresh_process_dir("omnipoint_command_names");
  return omnipoint::test::run_omnipoint(arguments, scratch);
}

// A refusal: a non-zero exit, nothing on stdout and exactly `line` on stderr.
void expect_refusal(const std::string& arguments, const std::string& line) {
  const CliRun result = run(arguments);
  EXPECT_NE(result.status, 0) << arguments;
  EXPECT_EQ(result.out, "") << arguments;
  EXPECT_EQ(result.err, "omnipoint: error: " + line + "\n") << arguments;
}

const std::string kCommands =
    "camera, data, eval, forward, init-model, metrics, models, predict, reproject, rig, synth, "
    "train, view";

TEST(CommandNames, AMistypedCommandNamesItselfAndTheCommandMeant) {
  expect_refusal("predcit x.jpg", "unknown command 'predcit' (did you mean 'predict'?)");
  expect_refusal("trian --config run.json", "unknown command 'trian' (did you mean 'train'?)");
  expect_refusal("evl", "unknown command 'evl' (did you mean 'eval'?)");
  // Options before the command do not hide it.
  expect_refusal("--bogus prdict x.jpg", "unknown command 'prdict' (did you mean 'predict'?)");
  // A command's own commands too.
  expect_refusal("camera fitt rays.npy",
                 "unknown command 'camera fitt' (did you mean 'camera fit'?)");
}

TEST(CommandNames, AWordFarFromEveryCommandGetsTheList) {
  expect_refusal("frobnicate x.jpg", "unknown command 'frobnicate'; the commands are " + kCommands);
  expect_refusal("camera calibrate",
                 "unknown command 'camera calibrate'; the camera commands are rays, info, fit");
}

TEST(CommandNames, AMissingCommandListsTheCommands) {
  const CliRun none = run("");
  EXPECT_NE(none.status, 0);
  EXPECT_EQ(none.err,
            "omnipoint: error: a command is required, one of " + kCommands + " (see --help)\n");
  const CliRun camera = run("camera");
  EXPECT_NE(camera.status, 0);
  EXPECT_EQ(camera.err,
            "omnipoint: error: camera needs a command, one of rays, info, fit (see camera "
            "--help)\n");
}

TEST(CommandNames, CommandsAndTheirArgumentsStillParse) {
  const CliRun version = run("--version");
  EXPECT_EQ(version.status, 0) << version.err;
  EXPECT_NE(version.out.find("omnipoint"), std::string::npos);
  // The licences of the code and of the bundled model, and where the fetched models' are.
  EXPECT_NE(version.out.find("\nlicence: Apache-2.0 (the code)\n"), std::string::npos)
      << version.out;
  EXPECT_NE(version.out.find("\nbundled model (omnipoint_default.safetensors): Apache-2.0"),
            std::string::npos)
      << version.out;
  EXPECT_NE(version.out.find("README, \"Licences\""), std::string::npos) << version.out;
  // Arguments after a command are its own, whatever they look like.
  for (const std::string help : {"predict --help", "camera rays --help", "train --help"}) {
    const CliRun result = run(help);
    EXPECT_EQ(result.status, 0) << help << ": " << result.err;
    EXPECT_NE(result.out.find("Usage"), std::string::npos) << help;
  }
  // A real command's own error is its own, not an unknown command.
  const CliRun info = run("camera info --camera 'PINHOLE 640 480 0 500 320 240'");
  EXPECT_NE(info.status, 0);
  EXPECT_EQ(info.err.find("unknown command"), std::string::npos) << info.err;
  EXPECT_NE(info.err.find("focal length fx must be > 0"), std::string::npos) << info.err;
}

}  // namespace
