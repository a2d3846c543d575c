// omnipoint: the command-line tool (contract in DESIGN.md).
#include <c10/util/Exception.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <iostream>

#include "cli/commands.h"
#include "cli/threads.h"
#include "omnipoint/io/process_memory.h"

// A function-try-block: nothing escapes main, not even from setting the commands up or from
// printing an error.
int main(int argc, char** argv) try {
  omnipoint::io::keep_freed_memory_in_heap();
  CLI::App app{"OmniPoint: a metric 3D point cloud from one image of any camera"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "omnipoint 0.1.0");
  omnipoint::cli::add_camera_command(app);
  omnipoint::cli::add_eval_command(app);
  omnipoint::cli::add_forward_command(app);
  omnipoint::cli::add_init_model_command(app);
  omnipoint::cli::add_metrics_command(app);
  omnipoint::cli::add_predict_command(app);
  omnipoint::cli::add_reproject_command(app);
  omnipoint::cli::add_synth_command(app);
  omnipoint::cli::add_train_command(app);
  omnipoint::cli::add_view_command(app);

  try {
    omnipoint::cli::use_threads(0);  // every core; a command's --threads overrides
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // Bad arguments: one line on stderr, like every other error (DESIGN.md).
    std::cerr << "omnipoint: error: " << e.what() << " (see --help)\n";
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
  return 0;
} catch (...) {
  std::fputs("omnipoint: error: the command line could not be set up or reported\n", stderr);
  return 1;
}
