#pragma once
// Loss and metric curves of a training run as one picture (`omnipoint train` writes
// OUTPUT_DIR/curves.png from log.jsonl at every checkpoint and at the end).
//
// One panel per series, three to a row: "loss" (the weighted total), each loss term, then
// "eval <entry>" for the periodic evaluations' total loss and benchmark scores (`*_rel`,
// `*_delta1`). x is the step; y is log-scaled when every value of the series is positive, else
// linear; each panel is labelled with its name and its y range. Per-step values are drawn light, their running mean (a window of
// 1/50 of the steps) dark; evaluations as dots. Skipped (non-finite) steps are left out.
#include <ATen/core/Tensor.h>
#include <nlohmann/json.hpp>

#include <vector>

namespace omnipoint::train {

// records: log.jsonl's objects in order. Returns (H, W, 3) uint8. std::invalid_argument when
// no record has a finite value to plot.
at::Tensor render_training_curves(const std::vector<nlohmann::json>& records);

}  // namespace omnipoint::train
