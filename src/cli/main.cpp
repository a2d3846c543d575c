// omnipoint: the command-line tool (contract in docs/DESIGN.md).
#include <c10/util/Exception.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/threads.h"
#include "omnipoint/io/process_memory.h"

namespace {

// The optimal-string-alignment distance: the fewest insertions, deletions, substitutions and
// swaps of neighbouring letters that turn `a` into `b` ("predcit" -> "predict" is one swap).
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + substitution});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

// The commands of `app` (CLI11 keeps option groups as unnamed subcommands too).
std::vector<const CLI::App*> commands_of(const CLI::App& app) {
  return app.get_subcommands([](const CLI::App* sub) { return !sub->get_name().empty(); });
}

// "a, b, c": the names of the commands of `app`.
std::string command_names(const CLI::App& app) {
  std::string names;
  for (const CLI::App* command : commands_of(app))
    names += (names.empty() ? "" : ", ") + command->get_name();
  return names;
}

// The error for a word in a command's place that names no command, else "". A command's
// place is the first argument that is no option, at the tool's level and at each command that
// has commands of its own (`camera rays`): these take no option with a value. A close
// misspelling is named: at most one edit per three letters, two at most.
std::string unknown_command_error(const CLI::App& app, int argc, char** argv) {
  const CLI::App* level = &app;
  std::string path;  // the commands so far, each followed by a space
  for (int i = 1; i < argc && !commands_of(*level).empty(); ++i) {
    const std::string word = argv[i];
    if (!word.empty() && word[0] == '-') continue;
    const CLI::App* named = nullptr;
    std::string closest;
    std::size_t closest_distance = std::string::npos;
    for (const CLI::App* command : commands_of(*level)) {
      if (command->check_name(word)) named = command;
      const std::size_t distance = edit_distance(word, command->get_name());
      if (distance < closest_distance) closest = command->get_name(), closest_distance = distance;
    }
    if (named == nullptr) {
      const std::string unknown = "unknown command '" + path + word + "'";
      if (closest_distance <= std::min<std::size_t>(2, std::max<std::size_t>(1, word.size() / 3)))
        return unknown + " (did you mean '" + path + closest + "'?)";
      return unknown + "; the " + path + "commands are " + command_names(*level);
    }
    level = named;
    path += named->get_name() + " ";
  }
  return "";
}

// The line for a command line that stops before a required command ("omnipoint", "omnipoint
// camera"), else "".
std::string missing_command_error(const CLI::App& app) {
  const CLI::App* level = &app;
  std::string path;  // the commands given, each followed by a space
  while (!level->get_subcommands().empty()) {
    level = level->get_subcommands().front();
    path += level->get_name() + " ";
  }
  if (level->get_require_subcommand_min() == 0 || commands_of(*level).empty()) return "";
  return (path.empty() ? "a command is required" : path + "needs a command") + ", one of " +
         command_names(*level) + " (see " + path + "--help)";
}

// Whether this is a sanitizer build (their leak and race reports run at a normal exit).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
constexpr bool kSanitized = __has_feature(address_sanitizer) || __has_feature(thread_sanitizer);
#else
constexpr bool kSanitized = false;
#endif

// The command is done and its files are written: flushes the standard streams and ends the
// process without the libraries' static destructors (LibTorch deregistering its thousands of
// operators: tens of milliseconds of every short run, docs/PERFORMANCE.md). Sanitizer builds
// end normally.
[[noreturn]] void exit_without_destructors(int status) {
  std::cout.flush();
  std::cerr.flush();
  std::fflush(nullptr);
  if (kSanitized) std::exit(status);
  std::_Exit(status);
}

}  // namespace

// A function-try-block: nothing escapes main, not even from setting the commands up or from
// printing an error.
int main(int argc, char** argv) try {
  omnipoint::io::keep_freed_memory_in_heap();
  CLI::App app{"OmniPoint: a metric 3D point cloud from one image of any camera"};
  app.require_subcommand(1);
  app.set_version_flag(
      "--version",
      "omnipoint " OMNIPOINT_VERSION
      "\nlicence: Apache-2.0 (the code)"
      "\nbundled model (omnipoint_default.safetensors): Apache-2.0, trained by this project from "
      "scratch on its own synthetic scenes"
      "\nmodels fetched by name keep their own licences (README, \"Licences\")");
  omnipoint::cli::add_camera_command(app);
  omnipoint::cli::add_data_command(app);
  omnipoint::cli::add_eval_command(app);
  omnipoint::cli::add_forward_command(app);
  omnipoint::cli::add_init_model_command(app);
  omnipoint::cli::add_metrics_command(app);
  omnipoint::cli::add_models_command(app);
  omnipoint::cli::add_predict_command(app);
  omnipoint::cli::add_reproject_command(app);
  omnipoint::cli::add_rig_command(app);
  omnipoint::cli::add_synth_command(app);
  omnipoint::cli::add_train_command(app);
  omnipoint::cli::add_view_command(app);

  try {
    const std::string unknown = unknown_command_error(app, argc, argv);
    if (!unknown.empty()) {
      std::cerr << "omnipoint: error: " << unknown << "\n";
      return static_cast<int>(CLI::ExitCodes::ExtrasError);
    }
    omnipoint::cli::use_threads(0);  // every core; a command's --threads overrides
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) exit_without_destructors(app.exit(e));  // --help, --version
    // Bad arguments: one line on stderr, like every other error (docs/DESIGN.md).
    const std::string missing =
        dynamic_cast<const CLI::RequiredError*>(&e) ? missing_command_error(app) : "";
    std::cerr << "omnipoint: error: "
              << (missing.empty() ? e.what() + std::string(" (see --help)") : missing) << "\n";
    return e.get_exit_code();
  } catch (const c10::Error& e) {
    // LibTorch's own errors carry a C++ trace after the message; users get the message.
    std::cerr << "omnipoint: error: " << e.what_without_backtrace() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "omnipoint: error: " << e.what() << "\n";
    return 1;
  } catch (...) {
    std::cerr << "omnipoint: error: an unknown exception\n";
    return 1;
  }
  exit_without_destructors(0);
} catch (...) {
  std::fputs("omnipoint: error: the command line could not be set up or reported\n", stderr);
  return 1;
}
