#include "omnipoint/predict/sequence_record.h"

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>

#include "omnipoint/io/atomic_file.h"

namespace omnipoint::predict {

std::optional<nlohmann::json> read_sequence_record(const std::filesystem::path& file,
                                                   ScaleMode mode) {
  if (!std::filesystem::is_regular_file(file)) return std::nullopt;
  nlohmann::json record;
  try {
    record = nlohmann::json::parse(io::read_file(file.string())).at("sequence");
  } catch (const std::exception&) {
    return std::nullopt;
  }
  const std::string recorded = record.value("scale_mode", "");
  if (recorded != scale_mode_name(mode))
    throw std::invalid_argument("--out " + file.parent_path().parent_path().string() +
                                " holds frames of a --scale " + recorded + " run (" +
                                file.string() + "): rerun with --scale " + recorded +
                                " or use another --out");
  return record;
}

}  // namespace omnipoint::predict
