#pragma once
// Files the tool ships (the model, the viewer's page): found beside an installed tool
// (<prefix>/bin/omnipoint -> <prefix>/<installed>), else where the build left them.
#include <filesystem>
#include <string>

namespace omnipoint::cli {

// The first that exists of <prefix>/`installed` (relative to the install prefix, which is found
// from the running executable) and `built` (a path in the source or build tree). Neither ->
// std::invalid_argument "<missing> is missing (looked for A and B)<advice>".
std::filesystem::path find_bundled(const std::string& installed, const std::string& built,
                                   const std::string& missing, const std::string& advice);

// The model a command runs: `given` (--model), else $OMNIPOINT_MODEL, else the bundled model
// (find_bundled). A hub reference (hf:..., a short name) is fetched into the cache first
// (resolve_model, cli/download_report.h).
std::string model_path_or_bundled(const std::string& given);

// Whether that is the bundled model: no --model, no $OMNIPOINT_MODEL.
bool bundled_model_chosen(const std::string& given);

// The one note `predict` gives on the bundled model (it never saw a real photograph), naming
// the command that fetches a real one.
extern const char* const kBundledModelNote;

}  // namespace omnipoint::cli
