#include "omnipoint/train/train_config.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <type_traits>

namespace omnipoint::train {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw std::invalid_argument("training config: " + where + ": " + what);
}

const json& object_at(const json& parent, const char* key, const std::string& where) {
  static const json kEmpty = json::object();
  if (!parent.contains(key)) return kEmpty;
  const json& value = parent.at(key);
  if (!value.is_object()) fail(where + "." + key, "expected a JSON object");
  return value;
}

void check_keys(const json& object, const std::set<std::string>& allowed,
                const std::string& where) {
  for (const auto& item : object.items())
    if (!allowed.count(item.key())) fail(where, "unknown key \"" + item.key() + "\"");
}

// A whole number of JSON `value` that T holds. nlohmann's get<T>() casts whatever it finds,
// and casting an out-of-range float to an integer is undefined behaviour.
template <typename T>
bool whole_number(const json& value, T& out) {
  using Limits = std::numeric_limits<T>;
  if (value.is_number_unsigned()) {
    const auto u = value.get<uint64_t>();
    if (u > static_cast<uint64_t>(Limits::max())) return false;
    out = static_cast<T>(u);
    return true;
  }
  if (value.is_number_integer()) {
    const auto i = value.get<int64_t>();
    if (i < 0 && (!Limits::is_signed || i < static_cast<int64_t>(Limits::min()))) return false;
    if (i > 0 && static_cast<uint64_t>(i) > static_cast<uint64_t>(Limits::max())) return false;
    out = static_cast<T>(i);
    return true;
  }
  if (value.is_number_float()) {
    const double d = value.get<double>();  // 1e4 is a fine step count
    if (!(d == std::trunc(d)) || d < static_cast<double>(Limits::min()) ||
        d >= std::ldexp(1.0, Limits::digits))
      return false;
    out = static_cast<T>(d);
    return true;
  }
  return false;
}

// `value` as T, or std::invalid_argument naming `where`.
template <typename T>
T convert(const json& value, const std::string& where) {
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    T out{};
    if (!whole_number(value, out)) fail(where, "expected an integer in range, got " + value.dump());
    return out;
  } else if constexpr (std::is_same_v<T, std::vector<int64_t>>) {
    if (!value.is_array()) fail(where, "expected an array of integers, got " + value.dump());
    T out;
    for (const json& item : value) out.push_back(convert<int64_t>(item, where));
    return out;
  } else {
    try {
      return value.get<T>();
    } catch (const json::exception&) {
      fail(where, "has the wrong type (" + value.dump() + ")");
    }
  }
}

template <typename T>
T value_or(const json& object, const char* key, T fallback, const std::string& where) {
  if (!object.contains(key)) return fallback;
  return convert<T>(object.at(key), where + "." + key);
}

template <typename T>
std::array<T, 2> pair_or(const json& object, const char* key, std::array<T, 2> fallback,
                         const std::string& where) {
  if (!object.contains(key)) return fallback;
  const json& value = object.at(key);
  if (!value.is_array() || value.size() != 2 || !value[0].is_number() || !value[1].is_number())
    fail(where + "." + key, "expected an array of two numbers");
  return {convert<T>(value[0], where + "." + key), convert<T>(value[1], where + "." + key)};
}

void require(bool ok, const std::string& where, const std::string& what) {
  if (!ok) fail(where, what);
}

}  // namespace

double StageConfig::lr_factor(int64_t in_stage) const {
  double factor = 1.0;
  if (schedule == Schedule::kStep) {
    // One factor per whole decay_every steps (integer division on purpose).
    const int64_t decays = decay_every > 0 ? in_stage / decay_every : 0;
    factor = std::pow(decay_factor, static_cast<double>(decays));
  } else {
    const double flat_end = flat_fraction * static_cast<double>(steps);
    const double decay_length = static_cast<double>(steps - 1) - flat_end;
    if (static_cast<double>(in_stage) > flat_end && decay_length > 0) {
      const double t = std::min(1.0, (static_cast<double>(in_stage) - flat_end) / decay_length);
      factor = final_factor + (1.0 - final_factor) * 0.5 * (1.0 + std::cos(M_PI * t));
    }
  }
  if (warmup_steps > 0 && in_stage < warmup_steps)
    factor *= static_cast<double>(in_stage + 1) / static_cast<double>(warmup_steps + 1);
  return factor;
}

int64_t TrainConfig::total_steps() const {
  int64_t total = 0;
  for (const StageConfig& stage : stages) total += stage.steps;
  return total;
}

TrainConfig TrainConfig::from_text(const std::string& text, const std::string& source) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& e) {
    throw std::invalid_argument("config " + source + ": not valid JSON (" + e.what() + ")");
  }
  try {
    return from_json(root);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("config " + source + ": " + e.what());
  }
}

TrainConfig TrainConfig::from_json(const json& root) {
  if (!root.is_object()) fail("file", "expected a JSON object");
  check_keys(root,
             {"output_dir", "seed", "threads", "precision", "device", "model", "init", "data",
              "conditions", "augment", "loss", "optimizer", "ema", "stages", "checkpoint_every",
              "log_every", "eval_every", "eval_batches", "max_nonfinite_steps"},
             "config");
  TrainConfig c;
  c.output_dir = value_or<std::string>(root, "output_dir", c.output_dir, "config");
  c.seed = value_or<uint64_t>(root, "seed", c.seed, "config");
  c.threads = value_or<int>(root, "threads", c.threads, "config");
  require(c.threads >= 1, "threads", "must be at least 1");
  try {
    c.precision =
        model::parse_precision(value_or<std::string>(root, "precision", "fp32", "config"));
  } catch (const std::invalid_argument& e) {
    fail("precision", e.what());
  }
  c.device = value_or<std::string>(root, "device", c.device, "config");
  require(c.device == "cpu" || c.device == "cuda", "device", "must be \"cpu\" or \"cuda\"");
  if (root.contains("model")) c.model = object_at(root, "model", "config");

  const json& init = object_at(root, "init", "config");
  check_keys(init, {"from", "path", "output"}, "init");
  c.init_from = value_or<std::string>(init, "from", c.init_from, "init");
  c.init_path = value_or<std::string>(init, "path", "", "init");
  c.init_output = value_or<std::string>(init, "output", c.init_output, "init");
  require(c.init_from == "scratch" || c.init_from == "dinov2" || c.init_from == "moge2" ||
              c.init_from == "omnipoint",
          "init.from", "expected scratch, dinov2, moge2 or omnipoint, got \"" + c.init_from + "\"");
  require(c.init_from == "scratch" || !c.init_path.empty(), "init.path",
          "required to initialise from " + c.init_from);
  require((c.init_from != "scratch" && c.init_from != "dinov2") || !c.model.is_null(), "model",
          "required (the network configuration) to initialise from " + c.init_from);
  if (c.init_from == "omnipoint" && !c.model.is_null())
    check_keys(c.model, {"conditioning", "num_tokens_range"},
               "model (from an OmniPoint checkpoint only \"conditioning\" and \"num_tokens_range\" "
               "may change)");

  const json& data = object_at(root, "data", "config");
  check_keys(data, {"batch_size", "image_size", "num_tokens", "datasets"}, "data");
  c.batch_size = value_or<int64_t>(data, "batch_size", c.batch_size, "data");
  require(c.batch_size >= 1, "data.batch_size", "must be at least 1");
  const auto size = pair_or<int64_t>(data, "image_size", {c.width, c.height}, "data");
  c.width = size[0];
  c.height = size[1];
  require(c.width >= 2 && c.height >= 2, "data.image_size",
          "must be [width, height], at least 2 each");
  c.num_tokens = pair_or<int64_t>(data, "num_tokens", c.num_tokens, "data");
  require(c.num_tokens[0] >= 1 && c.num_tokens[0] <= c.num_tokens[1], "data.num_tokens",
          "must be [min, max], 1 <= min <= max");
  if (!data.contains("datasets") || !data.at("datasets").is_array() || data.at("datasets").empty())
    fail("data.datasets", "expected a non-empty array of data sources");
  for (const json& entry : data.at("datasets")) {
    const std::string where = "data.datasets[" + std::to_string(c.datasets.size()) + "]";
    if (!entry.is_object()) fail(where, "expected a JSON object");
    check_keys(entry, {"weight", "synth", "folders", "image_size", "labels"}, where);
    DatasetSource source;
    source.weight = value_or<double>(entry, "weight", 1.0, where);
    require(source.weight > 0, where + ".weight", "must be positive");
    const auto bucket = pair_or<int64_t>(entry, "image_size", {c.width, c.height}, where);
    source.width = bucket[0];
    source.height = bucket[1];
    require(source.width >= 2 && source.height >= 2, where + ".image_size",
            "must be [width, height], at least 2 each");
    source.labelled = value_or<bool>(entry, "labels", true, where);
    require(entry.contains("synth") != entry.contains("folders"), where,
            "needs exactly one of \"synth\" or \"folders\"");
    if (entry.contains("synth")) {
      const json& synth = object_at(entry, "synth", where);
      check_keys(synth, {"scenes", "cameras"}, where + ".synth");
      source.synth = true;
      source.synth_source.scenes = value_or<std::vector<std::string>>(
          synth, "scenes", {"indoor", "outdoor", "object"}, where + ".synth");
      source.synth_source.cameras =
          value_or<std::vector<std::string>>(synth, "cameras", {}, where + ".synth");
      require(!source.synth_source.scenes.empty() && !source.synth_source.cameras.empty(),
              where + ".synth", "needs non-empty \"scenes\" and \"cameras\"");
    } else {
      source.folders = value_or<std::string>(entry, "folders", "", where);
    }
    c.datasets.push_back(source);
  }

  const json& conditions = object_at(root, "conditions", "config");
  check_keys(conditions, {"probability", "sparse_ratio"}, "conditions");
  c.condition_probability =
      value_or<double>(conditions, "probability", c.condition_probability, "conditions");
  require(c.condition_probability >= 0 && c.condition_probability <= 1, "conditions.probability",
          "must lie in [0, 1]");
  c.sparse_ratio = pair_or<double>(conditions, "sparse_ratio", c.sparse_ratio, "conditions");
  require(c.sparse_ratio[0] > 0 && c.sparse_ratio[0] <= c.sparse_ratio[1] && c.sparse_ratio[1] <= 1,
          "conditions.sparse_ratio", "must be [min, max] with 0 < min <= max <= 1");

  const json& augment = object_at(root, "augment", "config");
  check_keys(augment,
             {"p2a", "p2a_probability", "a2p", "a2p_probability", "a2p_teacher",
              "a2p_teacher_tokens", "photometric", "flip"},
             "augment");
  c.p2a = value_or<bool>(augment, "p2a", false, "augment");
  c.p2a_probability = value_or<double>(augment, "p2a_probability", c.p2a_probability, "augment");
  require(c.p2a_probability >= 0 && c.p2a_probability <= 1, "augment.p2a_probability",
          "must lie in [0, 1]");
  c.a2p = value_or<bool>(augment, "a2p", false, "augment");
  c.a2p_probability = value_or<double>(augment, "a2p_probability", c.a2p_probability, "augment");
  require(c.a2p_probability >= 0 && c.a2p_probability <= 1, "augment.a2p_probability",
          "must lie in [0, 1]");
  c.a2p_teacher = value_or<std::string>(augment, "a2p_teacher", "", "augment");
  c.a2p_teacher_tokens = value_or<int64_t>(augment, "a2p_teacher_tokens", 0, "augment");
  require(!c.a2p || !c.a2p_teacher.empty(), "augment.a2p_teacher",
          "A2P needs a teacher: the path of an OmniPoint checkpoint (e.g. the stage-1 model)");
  require(c.a2p_teacher_tokens >= 0, "augment.a2p_teacher_tokens",
          "must be >= 0 (0: the largest of num_tokens)");
  c.photometric = value_or<bool>(augment, "photometric", false, "augment");
  c.flip = value_or<bool>(augment, "flip", false, "augment");
  bool any_labelled = false;
  for (size_t i = 0; i < c.datasets.size(); ++i) {
    any_labelled = any_labelled || c.datasets[i].labelled;
    require(c.datasets[i].labelled || c.a2p, "data.datasets[" + std::to_string(i) + "].labels",
            "an unlabelled source needs augment.a2p (A2P pseudo-labels its items)");
  }
  require(any_labelled, "data.datasets", "needs at least one labelled source");

  const json& loss = object_at(root, "loss", "config");
  check_keys(loss, {"point_loss", "align_trunc", "align_points", "weights", "local"}, "loss");
  c.loss.point_loss =
      parse_point_loss(value_or<std::string>(loss, "point_loss", "decoupled", "loss"));
  c.loss.align_trunc = value_or<double>(loss, "align_trunc", c.loss.align_trunc, "loss");
  c.loss.align_points = value_or<int64_t>(loss, "align_points", c.loss.align_points, "loss");
  require(c.loss.align_points == 0 || c.loss.align_points >= 16, "loss.align_points",
          "must be 0 (every labelled pixel) or at least 16");
  const json& weights = object_at(loss, "weights", "loss");
  check_keys(weights, {"point", "ray", "metric", "normal", "local", "mask", "gauge"},
             "loss.weights");
  LossWeights& w = c.loss.weights;
  w.point = value_or<double>(weights, "point", w.point, "loss.weights");
  w.ray = value_or<double>(weights, "ray", w.ray, "loss.weights");
  w.metric = value_or<double>(weights, "metric", w.metric, "loss.weights");
  w.normal = value_or<double>(weights, "normal", w.normal, "loss.weights");
  w.local = value_or<double>(weights, "local", w.local, "loss.weights");
  w.mask = value_or<double>(weights, "mask", w.mask, "loss.weights");
  w.gauge = value_or<double>(weights, "gauge", w.gauge, "loss.weights");
  const json& local = object_at(loss, "local", "loss");
  check_keys(local, {"levels", "patches_per_item", "min_points", "fit_points"}, "loss.local");
  c.loss.local.levels =
      value_or<std::vector<int64_t>>(local, "levels", c.loss.local.levels, "loss.local");
  c.loss.local.patches_per_item =
      value_or<int64_t>(local, "patches_per_item", c.loss.local.patches_per_item, "loss.local");
  c.loss.local.min_points =
      value_or<int64_t>(local, "min_points", c.loss.local.min_points, "loss.local");
  c.loss.local.fit_points =
      value_or<int64_t>(local, "fit_points", c.loss.local.fit_points, "loss.local");
  require(c.loss.local.fit_points == 0 || c.loss.local.fit_points >= 3, "loss.local.fit_points",
          "must be 0 (all points) or at least 3");
  for (const int64_t level : c.loss.local.levels)
    require(level > 0, "loss.local.levels", "must be positive");
  require(c.loss.local.patches_per_item >= 1, "loss.local.patches_per_item", "must be at least 1");

  const json& optimizer = object_at(root, "optimizer", "config");
  check_keys(optimizer, {"weight_decay", "betas", "eps", "grad_clip"}, "optimizer");
  c.weight_decay = value_or<double>(optimizer, "weight_decay", c.weight_decay, "optimizer");
  c.betas = pair_or<double>(optimizer, "betas", c.betas, "optimizer");
  c.eps = value_or<double>(optimizer, "eps", c.eps, "optimizer");
  c.grad_clip = value_or<double>(optimizer, "grad_clip", c.grad_clip, "optimizer");
  require(c.grad_clip >= 0, "optimizer.grad_clip", "must be >= 0 (0: no clipping)");
  const json& ema = object_at(root, "ema", "config");
  check_keys(ema, {"decay"}, "ema");
  c.ema_decay = value_or<double>(ema, "decay", c.ema_decay, "ema");
  require(c.ema_decay >= 0 && c.ema_decay < 1, "ema.decay", "must lie in [0, 1)");

  if (!root.contains("stages") || !root.at("stages").is_array() || root.at("stages").empty())
    fail("stages", "expected a non-empty array of training stages");
  for (const json& entry : root.at("stages")) {
    const std::string where = "stages[" + std::to_string(c.stages.size()) + "]";
    if (!entry.is_object()) fail(where, "expected a JSON object");
    check_keys(entry,
               {"stage", "steps", "lr_backbone", "lr_heads", "schedule", "decay_every",
                "decay_factor", "flat_fraction", "final_factor", "warmup_steps"},
               where);
    StageConfig stage;
    stage.stage = value_or<int>(entry, "stage", stage.stage, where);
    require(stage.stage >= 1 && stage.stage <= 3, where + ".stage", "must be 1, 2 or 3");
    stage.steps = value_or<int64_t>(entry, "steps", 0, where);
    require(stage.steps >= 1, where + ".steps", "must be at least 1");
    stage.lr_backbone = value_or<double>(entry, "lr_backbone", stage.lr_backbone, where);
    stage.lr_heads = value_or<double>(entry, "lr_heads", stage.lr_heads, where);
    const auto schedule = value_or<std::string>(entry, "schedule", "step", where);
    require(schedule == "step" || schedule == "flat_cosine", where + ".schedule",
            "expected step or flat_cosine, got \"" + schedule + "\"");
    stage.schedule = schedule == "step" ? Schedule::kStep : Schedule::kFlatCosine;
    stage.decay_every = value_or<int64_t>(entry, "decay_every", stage.decay_every, where);
    stage.decay_factor = value_or<double>(entry, "decay_factor", stage.decay_factor, where);
    stage.flat_fraction = value_or<double>(entry, "flat_fraction", stage.flat_fraction, where);
    stage.final_factor = value_or<double>(entry, "final_factor", stage.final_factor, where);
    stage.warmup_steps = value_or<int64_t>(entry, "warmup_steps", stage.warmup_steps, where);
    require(stage.lr_backbone >= 0 && stage.lr_heads >= 0, where, "learning rates must be >= 0");
    require(stage.decay_every >= 0, where + ".decay_every", "must be >= 0");
    require(stage.flat_fraction >= 0 && stage.flat_fraction <= 1, where + ".flat_fraction",
            "must lie in [0, 1]");
    require(stage.final_factor >= 0 && stage.final_factor <= 1, where + ".final_factor",
            "must lie in [0, 1]");
    require(stage.warmup_steps >= 0 && stage.warmup_steps < stage.steps, where + ".warmup_steps",
            "must lie in [0, steps)");
    c.stages.push_back(stage);
  }
  c.checkpoint_every = value_or<int64_t>(root, "checkpoint_every", c.checkpoint_every, "config");
  c.log_every = value_or<int64_t>(root, "log_every", c.log_every, "config");
  c.eval_every = value_or<int64_t>(root, "eval_every", c.eval_every, "config");
  c.eval_batches = value_or<int64_t>(root, "eval_batches", c.eval_batches, "config");
  c.max_nonfinite_steps =
      value_or<int64_t>(root, "max_nonfinite_steps", c.max_nonfinite_steps, "config");
  require(c.checkpoint_every >= 0 && c.log_every >= 1 && c.eval_every >= 0 && c.eval_batches >= 1,
          "config", "checkpoint_every/eval_every must be >= 0, log_every/eval_batches >= 1");
  require(c.max_nonfinite_steps >= 1, "max_nonfinite_steps", "must be at least 1");
  return c;
}

}  // namespace omnipoint::train
