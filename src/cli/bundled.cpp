#include "cli/bundled.h"

#include <cstdlib>
#include <stdexcept>
#include <system_error>
#include <vector>

#include "cli/download_report.h"

namespace omnipoint::cli {

std::filesystem::path find_bundled(const std::string& installed, const std::string& built,
                                   const std::string& missing, const std::string& advice) {
  std::error_code error;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", error);
  std::vector<std::filesystem::path> candidates;
  if (!error) candidates.push_back(executable.parent_path().parent_path() / installed);
  candidates.emplace_back(built);
  std::string looked_for;
  for (const std::filesystem::path& candidate : candidates) {
    if (std::filesystem::exists(candidate)) return candidate;
    looked_for += (looked_for.empty() ? "" : " and ") + candidate.string();
  }
  throw std::invalid_argument(missing + " is missing (looked for " + looked_for + ")" + advice);
}

namespace {

std::string model_from_environment() {
  const char* environment = std::getenv("OMNIPOINT_MODEL");
  return environment != nullptr ? environment : "";
}

}  // namespace

const char* const kBundledModelNote =
    "the bundled model learned from synthetic scenes only (a demonstration of the pipeline; on "
    "real photos it does worse than a constant): for real photos fetch MoGe-2's, "
    "`omnipoint models pull moge-2-vitl-normal`, and pass --model moge-2-vitl-normal";

// Installed beside the tool (<prefix>/bin/omnipoint -> <prefix>/share/omnipoint/), else in the
// source tree it was built from.
std::string model_path_or_bundled(const std::string& given) {
  if (!given.empty()) return resolve_model(given);
  if (const std::string environment = model_from_environment(); !environment.empty())
    return resolve_model(environment);
  return find_bundled(OMNIPOINT_INSTALLED_MODEL, OMNIPOINT_SOURCE_MODEL,
                      "no model given and the bundled one", ": pass a checkpoint with --model FILE")
      .string();
}

bool bundled_model_chosen(const std::string& given) {
  return given.empty() && model_from_environment().empty();
}

}  // namespace omnipoint::cli
