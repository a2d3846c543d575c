#pragma once
// The "sequence" record of a frame a sequence run finished (camera.json of `predict --sequence`,
// rig.json of `predict --rig --sequence`): what a resumed run reads back to continue the
// running scale (scale_smoother.h). Internal to the two jobs.
#include <nlohmann/json_fwd.hpp>

#include <filesystem>
#include <optional>

#include "omnipoint/predict/scale_smoother.h"

namespace omnipoint::predict {

// The "sequence" object of the JSON file `file` in a frame folder of OUT, or nullopt when there
// is no such file or it holds no such object (the frame is not a finished one of a sequence: it
// is predicted again and its folder replaced). A record of another scale mode than `mode` is
// std::invalid_argument naming --scale and --out: the running estimate cannot continue it.
std::optional<nlohmann::json> read_sequence_record(const std::filesystem::path& file,
                                                   ScaleMode mode);

}  // namespace omnipoint::predict
