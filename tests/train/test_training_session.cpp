// The training session (train/training_session.h) on a tiny network and synthetic data: an
// interrupted (stop_after) or killed session resumes to exactly the uninterrupted one's log and
// weights, evaluations and curves, what the observer hears, and bad options.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/train/checkpoint.h"
#include "omnipoint/train/training_session.h"
#include "train/tiny_training.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Runs a session of `config` (JSON) to its end or to stop_after, from `resume` when given.
void run_session(const json& config, const std::string& resume = "", int64_t stop_after = 0,
                 TrainingObserver* observer = nullptr) {
  TrainingSessionOptions options;
  options.config = TrainConfig::from_json(config);
  options.resume = resume;
  options.stop_after = stop_after;
  TrainingSession(std::move(options), observer).Run();
}

// The two runs' final weights and EMA weights are the same, bit for bit.
void expect_same_weights(const std::string& a_dir, const std::string& b_dir) {
  for (const std::string file : {"model.safetensors", "model_ema.safetensors"}) {
    const auto a = io::read_safetensors(a_dir + "/" + file, std::nullopt).tensors;
    const auto b = io::read_safetensors(b_dir + "/" + file, std::nullopt).tensors;
    ASSERT_EQ(a.size(), b.size());
    for (const auto& [name, t] : a) EXPECT_TRUE(at::equal(t, b.at(name))) << file << " " << name;
  }
}

// What a session tells its observer.
struct Recorder : TrainingObserver {
  std::vector<TrainingProgress> steps;
  std::vector<std::string> warnings;
  std::vector<std::string> finished_with;
  void progress(const TrainingProgress& progress) override { steps.push_back(progress); }
  void warning(const std::string& text) override { warnings.push_back(text); }
  void finished(const std::string& model_path) override { finished_with.push_back(model_path); }
};

TEST(TrainingSession, ResumedRunEqualsUninterruptedRun) {
  const std::string root = temp_dir("resume");
  // Stage 2 with P2A and A2P: the teacher's pseudo-labels must resume exactly too.
  const model::OmniPointModel teacher = tiny_model(TrainConfig::from_json(tiny_config("x")));
  io::write_safetensors(root + "/teacher.safetensors", model::state_dict(*teacher),
                        model::omnipoint_metadata(teacher->config()));
  const auto config = [&](const std::string& name) {
    json config = tiny_config(root + "/" + name);
    config["checkpoint_every"] = 2;
    config["augment"] = {{"p2a", true},
                         {"p2a_probability", 0.5},
                         {"a2p", true},
                         {"a2p_teacher", root + "/teacher.safetensors"}};
    return config;
  };
  run_session(config("straight"));
  // Stopped after step 3 (mid stage 2), and as if killed before its checkpoint: `latest`
  // still names step 2, so the resumed run redoes step 3 and rewrites its log record.
  run_session(config("interrupted"), "", 3);
  EXPECT_FALSE(fs::exists(root + "/interrupted/model.safetensors"));
  ASSERT_TRUE(fs::exists(root + "/interrupted/checkpoints/step_00000003"));
  std::ofstream(root + "/interrupted/checkpoints/latest") << "step_00000002\n";
  run_session(config("interrupted"), root + "/interrupted");

  const auto expected = losses_by_step(root + "/straight/log.jsonl");
  const auto resumed = losses_by_step(root + "/interrupted/log.jsonl");
  ASSERT_EQ(expected.size(), 5u);
  EXPECT_EQ(resumed, expected);
  expect_same_weights(root + "/straight", root + "/interrupted");
  // Resuming from a checkpoint's step folder works too; a bad path is one clear error.
  EXPECT_NO_THROW(read_checkpoint(root + "/interrupted/checkpoints/step_00000005"));
  EXPECT_THROW(read_checkpoint(root + "/nothing"), std::runtime_error);
  EXPECT_THROW(run_session(config("interrupted"), root + "/nothing"), std::runtime_error);
  fs::remove_all(root);
}

// A real SIGKILL at an arbitrary moment (mid-step, mid-log line or mid-checkpoint) of a session
// in a child process: the resumed session ends with the uninterrupted one's weights and losses.
TEST(TrainingSession, KilledRunResumesToTheSameWeights) {
  const std::string root = temp_dir("kill");
  const auto config = [&](const std::string& name) {
    json config = tiny_config(root + "/" + name);
    config["stages"][0]["steps"] = 30;
    config["stages"][1]["steps"] = 30;
    config["checkpoint_every"] = 4;
    return config;
  };
  run_session(config("straight"));
  // Kill after a growing delay until a checkpoint exists and the run had not finished.
  bool interrupted = false;
  for (const int milliseconds : {1000, 2000, 4000, 8000}) {
    fs::remove_all(root + "/killed");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        run_session(config("killed"));
      } catch (...) {
        ::_exit(1);
      }
      ::_exit(0);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(milliseconds));
    ::kill(child, SIGKILL);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    interrupted = fs::exists(root + "/killed/checkpoints/latest") &&
                  !fs::exists(root + "/killed/model.safetensors");
    if (interrupted) break;
  }
  ASSERT_TRUE(interrupted) << "no delay killed the run between its first checkpoint and its end";
  run_session(config("killed"), root + "/killed");
  EXPECT_EQ(losses_by_step(root + "/killed/log.jsonl"),
            losses_by_step(root + "/straight/log.jsonl"));
  expect_same_weights(root + "/straight", root + "/killed");
  fs::remove_all(root);
}

TEST(TrainingSession, LogsBenchmarkScoresAndDrawsCurves) {
  const std::string root = temp_dir("curves");
  json config = tiny_config(root + "/run");
  config["eval_every"] = 2;
  config["eval_batches"] = 1;
  run_session(config);
  int evaluations = 0;
  std::istringstream lines(io::read_file(root + "/run/log.jsonl"));
  for (std::string line; std::getline(lines, line);) {
    const json record = json::parse(line);
    if (!record.contains("eval")) continue;
    ++evaluations;
    const double delta1 = record["eval"].at("points_delta1").get<double>();
    EXPECT_GE(delta1, 0.0);
    EXPECT_LE(delta1, 1.0);
    EXPECT_GT(record["eval"].at("points_rel").get<double>(), 0.0);
  }
  EXPECT_EQ(evaluations, 2);  // steps 2 and 4 of 5
  if (io::image_io_available()) {
    const at::Tensor curves = io::read_image(root + "/run/curves.png");
    EXPECT_EQ(curves.size(1), 1200);
    // Redrawn from the log alone (`train --curves-only`).
    fs::remove(root + "/run/curves.png");
    redraw_training_curves(root + "/run");
    EXPECT_EQ(io::read_image(root + "/run/curves.png").size(1), 1200);
  }
  EXPECT_THROW(redraw_training_curves(root + "/none"), std::runtime_error);
  fs::remove_all(root);
}

// eval_at_start scores the starting weights (a step-0 record); data.eval_datasets are what the
// evaluations score instead of the training sources' stream, opened with the run.
TEST(TrainingSession, EvaluatesTheStartAndTheHeldOutSources) {
  const std::string root = temp_dir("held_out");
  const auto evaluations = [](const std::string& log) {
    std::map<int64_t, double> points_rel;
    std::istringstream lines(io::read_file(log));
    for (std::string line; std::getline(lines, line);) {
      const json record = json::parse(line);
      if (record.contains("eval"))
        points_rel[record["step"].get<int64_t>()] = record["eval"].at("points_rel").get<double>();
    }
    return points_rel;
  };
  json config = tiny_config(root + "/training_sources");
  config["eval_every"] = 2;
  config["eval_batches"] = 1;
  config["eval_at_start"] = true;
  run_session(config);
  const std::map<int64_t, double> own = evaluations(root + "/training_sources/log.jsonl");
  EXPECT_EQ(own.size(), 3u);  // steps 0, 2 and 4 of 5
  EXPECT_EQ(own.count(0), 1u);

  config["output_dir"] = root + "/held_out";
  config["data"]["eval_datasets"] = {
      {{"synth", {{"scenes", {"object"}}, {"cameras", {"PINHOLE 28 28 30 30 14 14"}}}}}};
  run_session(config);
  const std::map<int64_t, double> held_out = evaluations(root + "/held_out/log.jsonl");
  ASSERT_EQ(held_out.size(), 3u);
  EXPECT_NE(held_out.at(0), own.at(0));  // other items, the same starting weights
  EXPECT_EQ(losses_by_step(root + "/held_out/log.jsonl"),
            losses_by_step(root + "/training_sources/log.jsonl"));  // training untouched

  config["data"]["eval_datasets"] = {{{"folders", root + "/missing"}}};
  const TrainConfig missing = TrainConfig::from_json(config);
  try {
    Trainer trainer(missing, tiny_model(missing));
    ADD_FAILURE() << "a missing held-out folder was not an error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("missing"), std::string::npos) << error.what();
  }
  fs::remove_all(root);
}

// Progress every log_every steps and at the session's last step, with the rate and the time
// left; the end names the weights; a session stopped early ends without them.
TEST(TrainingSession, TellsItsObserverTheProgressAndTheEnd) {
  const std::string root = temp_dir("observer");
  json config = tiny_config(root + "/run");
  config["log_every"] = 2;
  Recorder stopped;
  run_session(config, "", 3, &stopped);
  ASSERT_EQ(stopped.steps.size(), 2u);  // step 2 (log_every) and step 3 (the last)
  EXPECT_EQ(stopped.steps[0].record.step, 2);
  EXPECT_EQ(stopped.steps[1].record.step, 3);
  EXPECT_EQ(stopped.steps[1].record.stage, 2);
  EXPECT_EQ(stopped.steps[1].total_steps, 5);
  EXPECT_GT(stopped.steps[1].images_per_second, 0.0);
  EXPECT_GT(stopped.steps[1].seconds_left, 0.0);
  EXPECT_TRUE(stopped.finished_with.empty());
  EXPECT_TRUE(stopped.warnings.empty());

  Recorder resumed;
  run_session(config, root + "/run", 0, &resumed);
  ASSERT_EQ(resumed.steps.size(), 2u);  // steps 4 and 5
  EXPECT_EQ(resumed.steps[1].record.step, 5);
  EXPECT_EQ(resumed.steps[1].seconds_left, 0.0);
  EXPECT_EQ(resumed.finished_with, std::vector<std::string>{root + "/run/model.safetensors"});
  EXPECT_EQ(losses_by_step(root + "/run/log.jsonl").size(), 5u);
  fs::remove_all(root);
}

// A step with a non-finite loss is a warning (and skipped); too many in a row end the session.
TEST(TrainingSession, WarnsOfSkippedStepsAndStopsAfterTooMany) {
  const std::string root = temp_dir("nonfinite");
  json config = tiny_config(root + "/run");
  config["max_nonfinite_steps"] = 2;
  // Weights that make every loss NaN, as the session's initial network.
  const TrainConfig parsed = TrainConfig::from_json(config);
  const model::OmniPointModel network = tiny_model(parsed);
  {
    at::NoGradGuard no_grad;
    model::state_dict(*network).at("scale_head.0.weight").fill_(NAN);
  }
  const std::string init = root + "/nan.safetensors";
  io::write_safetensors(init, model::state_dict(*network),
                        model::omnipoint_metadata(network->config()));
  config.erase("model");
  config["init"] = {{"from", "omnipoint"}, {"path", init}};
  Recorder recorder;
  try {
    run_session(config, "", 0, &recorder);
    FAIL() << "no error after 2 non-finite steps";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("2 steps in a row"), std::string::npos) << e.what();
  }
  EXPECT_EQ(recorder.warnings,
            std::vector<std::string>{"step 1 skipped: non-finite loss or gradients"});
  fs::remove_all(root);
}

TEST(TrainingSession, BadOptionsAreOneClearError) {
  TrainingSessionOptions options;
  options.config = TrainConfig::from_json(tiny_config("x"));
  EXPECT_NO_THROW(options.Check());
  const auto message = [](const TrainingSessionOptions& bad) -> std::string {
    try {
      bad.Check();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  TrainingSessionOptions bad = options;
  bad.stop_after = -1;
  EXPECT_NE(message(bad).find("stop_after"), std::string::npos) << message(bad);
  bad = options;
  bad.config.output_dir.clear();
  EXPECT_NE(message(bad).find("output_dir"), std::string::npos) << message(bad);
  bad = options;
  bad.config.stages.clear();
  EXPECT_NE(message(bad).find("stages"), std::string::npos) << message(bad);
  bad = options;
  bad.config.log_every = 0;
  EXPECT_NE(message(bad).find("log_every"), std::string::npos) << message(bad);
  // Run() checks first: nothing is written.
  bad.config.output_dir = temp_dir("bad_options") + "/run";
  EXPECT_THROW(TrainingSession(bad).Run(), std::invalid_argument);
  EXPECT_FALSE(fs::exists(bad.config.output_dir));
  fs::remove_all(fs::path(bad.config.output_dir).parent_path());
}

}  // namespace
}  // namespace omnipoint::train
