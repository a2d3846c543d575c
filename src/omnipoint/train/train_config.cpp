#include "omnipoint/train/train_config.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "omnipoint/data/dataset.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/util/config.h"

namespace omnipoint::train {
namespace {

using nlohmann::json;
using util::ConfigScope;
using util::ConfigTable;

const char* const kDocument = "training config";

std::string init_name(InitSource source) {
  switch (source) {
    case InitSource::kDinoV2:
      return "dinov2";
    case InitSource::kMoGe2:
      return "moge2";
    case InitSource::kOmniPoint:
      return "omnipoint";
    case InitSource::kScratch:
      break;
  }
  return "scratch";
}

// A camera spec or camera file (io/camera_file.h), read once here; written as its spec line.
util::ConfigCodec<camera::Camera> camera_codec() {
  util::ConfigCodec<camera::Camera> codec;
  codec.read = [](const json& value, const ConfigScope& scope) {
    const std::string spec = util::config_json::read_text(value, scope);
    try {
      return io::read_camera(spec);
    } catch (const std::invalid_argument& e) {
      scope.fail(e.what());
    } catch (const std::runtime_error& e) {
      scope.fail(e.what());
    }
  };
  codec.write = [](const camera::Camera& camera, json& out) { out = camera.to_spec(); };
  return codec;
}

// "image_size": [W, H] into two members.
template <typename T>
void image_size_field(ConfigTable<T>& table, int64_t T::*width, int64_t T::*height,
                      const char* doc) {
  const auto codec = util::array_codec<int64_t, 2>(util::integer_codec<int64_t>());
  table.custom(
      "image_size",
      [=](const json& value, T& out, const ConfigScope& scope) {
        const std::array<int64_t, 2> size = codec.read(value, scope);
        out.*width = size[0];
        out.*height = size[1];
      },
      [=](const T& in, json& out) {
        codec.write({in.*width, in.*height}, out);
      },
      [=](const T& in, const ConfigScope& scope) {
        if (in.*width < 2 || in.*height < 2) scope.fail("must be [width, height], at least 2 each");
      },
      doc);
}

const ConfigTable<SynthSource>& synth_table() {
  static const ConfigTable<SynthSource> table = [] {
    ConfigTable<SynthSource> t;
    using data::synth::SceneKind;
    t.field("scenes", &SynthSource::scenes,
            util::list_codec(util::enum_codec(util::enum_names(
                std::vector<SceneKind>{SceneKind::kIndoor, SceneKind::kOutdoor, SceneKind::kObject},
                data::synth::scene_kind_name))),
            "scene kinds drawn per item")
        .non_empty();
    t.field("cameras", &SynthSource::cameras, util::list_codec(camera_codec()),
            "camera specs or files, drawn per item")
        .non_empty();
    return t;
  }();
  return table;
}

// A JSON object of strings (a format's options) as a map.
util::ConfigCodec<std::map<std::string, std::string>> text_map_codec() {
  util::ConfigCodec<std::map<std::string, std::string>> codec;
  codec.read = [](const json& value, const ConfigScope& scope) {
    std::map<std::string, std::string> out;
    for (const std::string& key : util::config_json::object_keys(value, scope))
      out[key] = util::config_json::read_text(value.at(key), scope.key(key));
    return out;
  };
  codec.write = [](const std::map<std::string, std::string>& in, json& out) {
    util::config_json::make_object(out);
    for (const auto& [key, text] : in) out[key] = text;
  };
  return codec;
}

// "a, b, c" (or "none").
std::string listed(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text.empty() ? std::string("none") : text;
}

// A native source's format and options, checked against the registered readers at load, so
// that a typo fails before any data is opened.
void check_native_source(const DatasetSource& source, const ConfigScope& scope) {
  if (source.format.empty()) return;
  if (source.root.empty())
    scope.key("root").fail("required with \"format\" (the dataset's root folder)");
  for (const data::DatasetFormat& format : data::dataset_format_list()) {
    if (format.name != source.format) continue;
    std::vector<std::string> known;
    for (const auto& option : format.options) known.push_back(option.first);
    for (const auto& option : source.options)
      if (format.options.count(option.first) == 0)
        scope.key("options")
            .key(option.first)
            .fail("not an option of format \"" + source.format +
                  "\" (its options: " + listed(known) + ")");
    return;
  }
  scope.key("format").fail("unknown dataset format \"" + source.format +
                           "\" (known: " + listed(data::dataset_formats()) + ")");
}

const ConfigTable<DatasetSource>& source_table() {
  static const ConfigTable<DatasetSource> table = [] {
    ConfigTable<DatasetSource> t;
    t.field("weight", &DatasetSource::weight, "its share of the items").positive();
    t.exactly_one_of({"synth", "folders", "format"});
    t.custom(
         "synth",
         [](const json& value, DatasetSource& source, const ConfigScope& scope) {
           source.synth = true;
           source.synth_source = synth_table().read(value, scope);
         },
         [](const DatasetSource& source, json& out) {
           synth_table().write(source.synth_source, out);
         },
         [](const DatasetSource& source, const ConfigScope& scope) {
           if (source.synth) synth_table().check(source.synth_source, scope);
         },
         "scenes rendered on the fly")
        .written_if([](const DatasetSource& source) { return source.synth; });
    t.field("folders", &DatasetSource::folders, "a directory of sample folders")
        .written_if(
            [](const DatasetSource& source) { return !source.synth && source.format.empty(); });
    const auto native = [](const DatasetSource& source) { return !source.format.empty(); };
    const char* const kWithFormat = "\"format\"";
    t.field("format", &DatasetSource::format, "a dataset format (omnipoint data formats)")
        .written_if(native);
    t.field("root", &DatasetSource::root, "the dataset's root folder").when(native, kWithFormat);
    t.field("split", &DatasetSource::split, "the format's split name or a split-list file")
        .when(native, kWithFormat)
        .written_if([](const DatasetSource& source) { return !source.split.empty(); });
    t.field("options", &DatasetSource::options, text_map_codec(), "the format's options")
        .when(native, kWithFormat)
        .written_if([](const DatasetSource& source) { return !source.options.empty(); });
    image_size_field(t, &DatasetSource::width, &DatasetSource::height,
                     "this source's aspect bucket (default: data.image_size)");
    t.field("labels", &DatasetSource::labelled, "false: its items enter only through A2P");
    t.rule(check_native_source);
    return t;
  }();
  return table;
}

// A list of sources ("datasets", "eval_datasets"); each bucket defaults to data.image_size.
ConfigTable<TrainConfig>::Custom source_list_field(
    ConfigTable<TrainConfig>& data, const std::string& key,
    std::vector<DatasetSource> TrainConfig::*member) {
  return data.custom(
      key,
      [member](const json& value, TrainConfig& c, const ConfigScope& scope) {
        const std::size_t count = util::config_json::array_size(value, scope);
        (c.*member).clear();
        for (std::size_t i = 0; i < count; ++i) {
          DatasetSource source;  // its bucket defaults to data.image_size, read above
          source.width = c.width;
          source.height = c.height;
          source_table().read_into(util::config_json::array_item(value, i), source, scope.index(i));
          (c.*member).push_back(std::move(source));
        }
      },
      [member](const TrainConfig& c, json& out) {
        util::config_json::make_array(out);
        for (const DatasetSource& source : c.*member)
          source_table().write(source, util::config_json::append(out));
      },
      [member](const TrainConfig& c, const ConfigScope& scope) {
        for (std::size_t i = 0; i < (c.*member).size(); ++i)
          source_table().check((c.*member)[i], scope.index(i));
      });
}

const ConfigTable<StageConfig>& stage_table() {
  static const ConfigTable<StageConfig> table = [] {
    ConfigTable<StageConfig> t;
    t.field("stage", &StageConfig::stage)
        .check([](int stage) { return stage >= 1 && stage <= 3; }, "must be 1, 2 or 3");
    t.field("steps", &StageConfig::steps).at_least(1);
    t.field("lr_backbone", &StageConfig::lr_backbone).at_least(0.0);
    t.field("lr_heads", &StageConfig::lr_heads).at_least(0.0);
    t.field("schedule", &StageConfig::schedule,
            util::enum_codec<Schedule>(
                {{"step", Schedule::kStep}, {"flat_cosine", Schedule::kFlatCosine}}));
    t.field("decay_every", &StageConfig::decay_every, "0: constant").at_least(0);
    t.field("decay_factor", &StageConfig::decay_factor);
    t.field("flat_fraction", &StageConfig::flat_fraction).range(0.0, 1.0);
    t.field("final_factor", &StageConfig::final_factor).range(0.0, 1.0);
    t.field("warmup_steps", &StageConfig::warmup_steps);
    t.rule([](const StageConfig& stage, const ConfigScope& scope) {
      if (stage.warmup_steps < 0 || stage.warmup_steps >= stage.steps)
        scope.key("warmup_steps").fail("must lie in [0, steps)");
    });
    return t;
  }();
  return table;
}

const ConfigTable<LossWeights>& weights_table() {
  static const ConfigTable<LossWeights> table = [] {
    ConfigTable<LossWeights> t;
    t.field("point", &LossWeights::point);
    t.field("ray", &LossWeights::ray);
    t.field("metric", &LossWeights::metric);
    t.field("normal", &LossWeights::normal);
    t.field("local", &LossWeights::local);
    t.field("mask", &LossWeights::mask);
    t.field("gauge", &LossWeights::gauge);
    return t;
  }();
  return table;
}

const ConfigTable<LocalLossOptions>& local_table() {
  static const ConfigTable<LocalLossOptions> table = [] {
    ConfigTable<LocalLossOptions> t;
    t.field("levels", &LocalLossOptions::levels)
        .check(
            [](const std::vector<int64_t>& levels) {
              return std::all_of(levels.begin(), levels.end(), [](int64_t l) { return l > 0; });
            },
            "must be positive");
    t.field("patches_per_item", &LocalLossOptions::patches_per_item).at_least(1);
    t.field("min_points", &LocalLossOptions::min_points);
    t.field("fit_points", &LocalLossOptions::fit_points)
        .check([](int64_t n) { return n == 0 || n >= 3; }, "must be 0 (all points) or at least 3");
    return t;
  }();
  return table;
}

const ConfigTable<LossConfig>& loss_table() {
  static const ConfigTable<LossConfig> table = [] {
    ConfigTable<LossConfig> t;
    t.field("point_loss", &LossConfig::point_loss, util::enum_codec(point_loss_names()));
    t.field("align_trunc", &LossConfig::align_trunc);
    t.field("align_points", &LossConfig::align_points)
        .check([](int64_t n) { return n == 0 || n >= 16; },
               "must be 0 (every labelled pixel) or at least 16");
    t.field("weights", &LossConfig::weights, util::struct_codec(weights_table()));
    t.field("local", &LossConfig::local, util::struct_codec(local_table()));
    return t;
  }();
  return table;
}

const ConfigTable<TrainConfig>& train_table() {
  static const ConfigTable<TrainConfig> table = [] {
    using model::Precision;
    ConfigTable<TrainConfig> t;
    t.field("output_dir", &TrainConfig::output_dir);
    t.field("seed", &TrainConfig::seed);
    t.field("threads", &TrainConfig::threads).at_least(1);
    t.field(
        "precision", &TrainConfig::precision,
        util::enum_codec(util::enum_names(
            std::vector<Precision>{Precision::kFloat32, Precision::kBFloat16, Precision::kFloat16},
            model::precision_name)));
    t.field(
        "device", &TrainConfig::device,
        util::enum_codec<TrainDevice>({{"cpu", TrainDevice::kCpu}, {"cuda", TrainDevice::kCuda}}));
    t.custom(
         "model",
         [](const json& value, TrainConfig& c, const ConfigScope& scope) {
           if (!value.is_object())
             scope.fail("expected a JSON object, got " + util::config_json::short_text(value));
           c.model = value;
         },
         [](const TrainConfig& c, json& out) { out = c.model; }, {},
         "the network's OmniPointConfig")
        .written_if([](const TrainConfig& c) { return !c.model.is_null(); });

    ConfigTable<TrainConfig>& init = t.section("init");
    init.field("from", &TrainConfig::init_from,
               util::enum_codec(util::enum_names(
                   std::vector<InitSource>{InitSource::kScratch, InitSource::kDinoV2,
                                           InitSource::kMoGe2, InitSource::kOmniPoint},
                   init_name)));
    init.field("path", &TrainConfig::init_path);
    init.field("output", &TrainConfig::init_output, util::enum_codec(model::output_kind_names()));

    ConfigTable<TrainConfig>& data = t.section("data");
    data.field("batch_size", &TrainConfig::batch_size).at_least(1);
    image_size_field(data, &TrainConfig::width, &TrainConfig::height, "the default bucket");
    data.field("num_tokens", &TrainConfig::num_tokens)
        .check([](const std::array<int64_t, 2>& n) { return n[0] >= 1 && n[0] <= n[1]; },
               "must be [min, max], 1 <= min <= max");
    const char* const kNoSources = "expected a non-empty array of data sources";
    source_list_field(data, "datasets", &TrainConfig::datasets).required(kNoSources);
    data.rule([kNoSources](const TrainConfig& c, const ConfigScope& scope) {
      if (c.datasets.empty()) scope.key("datasets").fail(kNoSources);
    });
    source_list_field(data, "eval_datasets", &TrainConfig::eval_datasets)
        .written_if([](const TrainConfig& c) { return !c.eval_datasets.empty(); });
    ConfigTable<TrainConfig>& conditions = t.section("conditions", "from stage 2 on");
    conditions.field("probability", &TrainConfig::condition_probability).range(0.0, 1.0);
    conditions.field("sparse_ratio", &TrainConfig::sparse_ratio)
        .check([](const std::array<double, 2>& r) { return r[0] > 0 && r[0] <= r[1] && r[1] <= 1; },
               "must be [min, max] with 0 < min <= max <= 1");

    ConfigTable<TrainConfig>& augment = t.section("augment");
    augment.field("p2a", &TrainConfig::p2a);
    augment.field("p2a_probability", &TrainConfig::p2a_probability).range(0.0, 1.0);
    augment.field("a2p", &TrainConfig::a2p);
    augment.field("a2p_probability", &TrainConfig::a2p_probability).range(0.0, 1.0);
    augment.field("a2p_teacher", &TrainConfig::a2p_teacher);
    augment.field("a2p_teacher_tokens", &TrainConfig::a2p_teacher_tokens)
        .check([](int64_t n) { return n >= 0; }, "must be >= 0 (0: the largest of num_tokens)");
    augment.field("photometric", &TrainConfig::photometric);
    augment.field("flip", &TrainConfig::flip);

    t.field("loss", &TrainConfig::loss, util::struct_codec(loss_table()));
    ConfigTable<TrainConfig>& optimizer = t.section("optimizer");
    optimizer.field("weight_decay", &TrainConfig::weight_decay);
    optimizer.field("betas", &TrainConfig::betas);
    optimizer.field("eps", &TrainConfig::eps);
    optimizer.field("grad_clip", &TrainConfig::grad_clip)
        .check([](double clip) { return clip >= 0; }, "must be >= 0 (0: no clipping)");
    t.section("ema")
        .field("decay", &TrainConfig::ema_decay)
        .check([](double decay) { return decay >= 0 && decay < 1; }, "must lie in [0, 1)");

    const char* const kNoStages = "expected a non-empty array of training stages";
    t.field("stages", &TrainConfig::stages, util::list_codec(util::struct_codec(stage_table())))
        .required(kNoStages)
        .non_empty(kNoStages);
    t.field("checkpoint_every", &TrainConfig::checkpoint_every, "0: only at the end").at_least(0);
    t.field("log_every", &TrainConfig::log_every).at_least(1);
    t.field("eval_every", &TrainConfig::eval_every, "0: only at the end").at_least(0);
    t.field("eval_batches", &TrainConfig::eval_batches).at_least(1);
    t.field("max_nonfinite_steps", &TrainConfig::max_nonfinite_steps).at_least(1);
    t.field("eval_at_start", &TrainConfig::eval_at_start, "also evaluate before the first step");

    t.rule([](const TrainConfig& c, const ConfigScope& scope) {
      const std::string from = init_name(c.init_from);
      if (c.init_from != InitSource::kScratch && c.init_path.empty())
        scope.key("init").key("path").fail("required to initialise from " + from);
      const bool needs_model =
          c.init_from == InitSource::kScratch || c.init_from == InitSource::kDinoV2;
      if (needs_model && c.model.is_null())
        scope.key("model").fail("required (the network configuration) to initialise from " + from);
      if (c.init_from == InitSource::kOmniPoint && c.model.is_object()) {
        for (const auto& item : c.model.items())
          if (item.key() != "conditioning" && item.key() != "num_tokens_range")
            scope.key("model")
                .key(item.key())
                .fail(
                    "from an OmniPoint checkpoint only \"conditioning\" and \"num_tokens_range\" "
                    "may change");
      }
      if (c.a2p && c.a2p_teacher.empty())
        scope.key("augment")
            .key("a2p_teacher")
            .fail(
                "A2P needs a teacher: the path of an OmniPoint checkpoint (e.g. the stage-1 "
                "model)");
      bool any_labelled = false;
      for (std::size_t i = 0; i < c.datasets.size(); ++i) {
        any_labelled = any_labelled || c.datasets[i].labelled;
        if (!c.datasets[i].labelled && !c.a2p)
          scope.key("data")
              .key("datasets")
              .index(i)
              .key("labels")
              .fail("an unlabelled source needs augment.a2p (A2P pseudo-labels its items)");
      }
      if (!any_labelled)
        scope.key("data").key("datasets").fail("needs at least one labelled source");
      for (std::size_t i = 0; i < c.eval_datasets.size(); ++i)
        if (!c.eval_datasets[i].labelled)
          scope.key("data")
              .key("eval_datasets")
              .index(i)
              .key("labels")
              .fail("an evaluation source needs labels");
    });
    return t;
  }();
  return table;
}

// `call`'s std::invalid_argument with "config SOURCE: " in front.
template <typename Call>
TrainConfig naming_source(const std::string& source, Call call) {
  try {
    return call();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("config " + source + ": " + e.what());
  }
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

TrainConfig TrainConfig::from_json(const json& json) {
  return util::read_config(train_table(), json, kDocument);
}

TrainConfig TrainConfig::from_text(const std::string& text, const std::string& source) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& e) {
    throw std::invalid_argument("config " + source + ": not valid JSON (" + e.what() + ")");
  }
  return naming_source(source, [&] { return from_json(root); });
}

TrainConfig TrainConfig::load(const std::string& path, const std::vector<std::string>& overrides) {
  json root = util::read_config_file(path);
  for (const std::string& assignment : overrides) util::apply_config_override(root, assignment);
  return naming_source(path, [&] { return from_json(root); });
}

json TrainConfig::to_json() const {
  json out;
  train_table().write(*this, out);
  return out;
}

}  // namespace omnipoint::train
