#pragma once
// Each subcommand lives in its own file and registers itself on the root app. A command's
// callback only parses arguments, calls the library and reports; errors are thrown as
// exceptions and turned into one line on stderr by main().
namespace CLI {
class App;
}

namespace omnipoint::cli {

void add_camera_command(CLI::App& app);
void add_data_command(CLI::App& app);
void add_eval_command(CLI::App& app);
void add_forward_command(CLI::App& app);
void add_init_model_command(CLI::App& app);
void add_metrics_command(CLI::App& app);
void add_models_command(CLI::App& app);
void add_predict_command(CLI::App& app);
void add_reproject_command(CLI::App& app);
void add_rig_command(CLI::App& app);
void add_synth_command(CLI::App& app);
void add_train_command(CLI::App& app);
void add_view_command(CLI::App& app);

}  // namespace omnipoint::cli
