#include "omnipoint/train/trainer.h"

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <ATen/Context.h>
#include <torch/nn/utils/clip_grad.h>
#include <torch/optim/adamw.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "omnipoint/eval/metrics.h"
#include "omnipoint/io/torch_checkpoint.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/precision.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/train/distributed.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::train {
namespace {

const DistributedContext kOneProcess;  // the default: one process, no communication

constexpr uint64_t kLossStream = 2;  // local-loss anchors
constexpr uint64_t kEvalStream = 1;  // evaluation batches

bool is_backbone(const std::string& name) {
  return name.rfind("encoder.backbone.", 0) == 0;
}
bool is_mask_head(const std::string& name) {
  return name.rfind("mask_head.", 0) == 0;
}

// The optimiser's per-parameter state is keyed by the parameter's TensorImpl: as text of its
// address in LibTorch 1.13, as the address itself in later versions.
template <typename Key>
Key state_key_of(const at::Tensor& parameter) {
  if constexpr (std::is_same_v<Key, std::string>) {
    std::ostringstream text;
    text << parameter.unsafeGetTensorImpl();
    return text.str();
  } else {
    return parameter.unsafeGetTensorImpl();
  }
}
auto state_key(const at::Tensor& parameter) {
  using Key = std::decay_t<decltype(std::declval<torch::optim::AdamW&>().state())>::key_type;
  return state_key_of<Key>(parameter);
}

}  // namespace

model::OmniPointModel build_model(const TrainConfig& config) {
  using namespace model;
  at::manual_seed(config.seed);  // the initial weights of fresh layers follow the config's seed
  if (config.init_from == InitSource::kOmniPoint) {
    const io::WeightsFile file = io::read_weights(config.init_path);
    if (config.model.is_null()) return load_omnipoint_model(file.tensors, file.metadata);
    // Fine-tuning with other condition branches (the state-embedding and smoothing ablations
    // start from one stage-1 model) or another default token budget: what both share loads, a
    // branch the file lacks starts as constructed (zero fusion), one the config drops is left out.
    nlohmann::json merged =
        nlohmann::json::parse(config_from_metadata(file.metadata).to_json_text());
    for (const auto& [key, value] : config.model.items()) merged[key] = value;
    OmniPointModel network(OmniPointConfig::from_json(merged));
    const LoadReport report = load_state_dict(*network, file.tensors, LoadMode::kPartial);
    for (const std::string& name : report.missing)
      if (!is_conditioning_tensor(name))
        throw std::invalid_argument("init.path \"" + config.init_path + "\": lacks \"" + name +
                                    "\", which is not a conditioning tensor");
    if (!report.mismatched.empty())
      throw std::invalid_argument("init.path \"" + config.init_path + "\": \"" +
                                  report.mismatched.front() +
                                  "\" has another shape than the config's");
    return network;
  }
  if (config.init_from == InitSource::kMoGe2) {
    const io::WeightsFile file = io::read_weights(config.init_path);
    const auto found = file.metadata.find("config");
    if (found == file.metadata.end())
      throw std::invalid_argument("init.path \"" + config.init_path +
                                  "\": a MoGe-2 checkpoint needs its config in the metadata");
    const MoGe2Config moge2 = MoGe2Config::from_json_text(found->second);
    OmniPointConfig omni_config = OmniPointConfig::from_moge2(moge2, config.init_output);
    if (!config.model.is_null() && config.model.contains("conditioning"))
      omni_config.conditioning = OmniPointConfig::from_json(config.model).conditioning;
    OmniPointModel network(omni_config);
    init_from_moge2(*network, file.tensors, moge2);
    return network;
  }
  OmniPointModel network(OmniPointConfig::from_json(config.model));
  if (config.init_from == InitSource::kDinoV2)
    init_from_dinov2(*network, io::read_weights(config.init_path).tensors);
  return network;
}

Trainer::Trainer(TrainConfig config, model::OmniPointModel network)
    : Trainer(std::move(config), std::move(network), kOneProcess) {}

namespace {

// "cuda" is the GPU of the process's LOCAL_RANK (one process per GPU, docs/TRAINING.md).
at::Device training_device(TrainDevice device, int local_rank) {
  if (device == TrainDevice::kCpu) return at::kCPU;
  if (!at::hasCUDA())
    throw std::invalid_argument(
        "training: device \"cuda\": this build has no CUDA (LibTorch without CUDA, or no GPU "
        "visible); use \"cpu\"");
  return {at::kCUDA, static_cast<c10::DeviceIndex>(local_rank)};
}

// The batches of the held-out sources (data.eval_datasets), their items as they are; null
// without any.
std::unique_ptr<BatchSource> held_out_source(const TrainConfig& config) {
  if (config.eval_datasets.empty()) return nullptr;
  TrainConfig held_out = config;
  held_out.datasets = config.eval_datasets;
  held_out.eval_datasets.clear();
  held_out.p2a = held_out.a2p = held_out.photometric = held_out.flip = false;
  return std::make_unique<BatchSource>(held_out);
}

}  // namespace

Trainer::Trainer(TrainConfig config, model::OmniPointModel network,
                 const DistributedContext& distributed)
    : config_(std::move(config)),
      device_(training_device(config_.device, distributed.local_rank())),
      model_(std::move(network)),
      distributed_(distributed),
      rank_(distributed.rank()),
      world_size_(distributed.world_size()),
      source_(config_),
      eval_source_(held_out_source(config_)) {
  if (config_.stages.empty()) throw std::invalid_argument("training: the config has no stages");
  util::set_threads(config_.threads);
  model_->to(device_);
  distributed_.broadcast_module(*model_);
  at::NoGradGuard no_grad;
  for (const auto& [name, tensor] : model::state_dict(*model_)) ema_[name] = tensor.clone();
}

Trainer::~Trainer() = default;

int Trainer::stage_index(int64_t step) const {
  int64_t end = 0;
  for (size_t i = 0; i < config_.stages.size(); ++i) {
    end += config_.stages[i].steps;
    if (step < end) return static_cast<int>(i);
  }
  return static_cast<int>(config_.stages.size()) - 1;
}

int64_t Trainer::stage_start(int index) const {
  int64_t start = 0;
  for (int i = 0; i < index; ++i) start += config_.stages[i].steps;
  return start;
}

void Trainer::configure_stage(int index) {
  const bool mask_only = config_.stages[index].stage == 3;
  std::vector<std::string> backbone, heads;
  std::vector<at::Tensor> backbone_params, head_params;
  for (auto& item : model_->named_parameters()) {
    const bool trainable = !mask_only || is_mask_head(item.key());
    item.value().set_requires_grad(trainable);
    if (!trainable) continue;
    if (is_backbone(item.key())) {
      backbone.push_back(item.key());
      backbone_params.push_back(item.value());
    } else {
      heads.push_back(item.key());
      head_params.push_back(item.value());
    }
  }
  torch::optim::AdamWOptions defaults(config_.stages[index].lr_heads);
  defaults.betas({config_.betas[0], config_.betas[1]})
      .eps(config_.eps)
      .weight_decay(config_.weight_decay);
  std::vector<torch::optim::OptimizerParamGroup> groups;
  group_names_.clear();
  group_kinds_.clear();
  if (!backbone_params.empty()) {
    groups.emplace_back(backbone_params, std::make_unique<torch::optim::AdamWOptions>(defaults));
    group_names_.push_back(backbone);
    group_kinds_.emplace_back("backbone");
  }
  groups.emplace_back(head_params, std::make_unique<torch::optim::AdamWOptions>(defaults));
  group_names_.push_back(heads);
  group_kinds_.emplace_back("heads");
  optimizer_ = std::make_unique<torch::optim::AdamW>(std::move(groups), defaults);
  current_stage_ = index;
}

LossConfig Trainer::stage_loss(int index) const {
  LossConfig loss = config_.loss;
  if (config_.stages[index].stage == 3) loss.weights = {0, 0, 0, 0, 0, config_.loss.weights.mask};
  return loss;
}

model::OmniPointOutput Trainer::forward(const TrainingBatch& batch, bool conditions) {
  model::OmniPointInputs inputs;
  inputs.image = batch.image;
  const model::ConditioningConfig& conditioning = model_->config().conditioning;
  if (conditions && conditioning.intrinsics) inputs.rays = batch.condition_rays;
  if (conditions && conditioning.sparse_depth) inputs.sparse_depth = batch.condition_sparse_depth;
  const model::AutocastScope autocast(config_.precision, batch.image.device().type());
  return model_->forward(inputs, batch.num_tokens);
}

StepRecord Trainer::train_step() {
  if (done()) throw std::logic_error("training: all stages are done");
  const int index = stage_index(step_);
  if (index != current_stage_) configure_stage(index);
  const StageConfig& stage = config_.stages[index];
  const double decay = stage.lr_factor(step_ - stage_start(index));
  StepRecord record;
  record.stage = stage.stage;
  record.lr_backbone = stage.lr_backbone * decay;
  record.lr_heads = stage.lr_heads * decay;
  for (size_t g = 0; g < group_kinds_.size(); ++g)
    static_cast<torch::optim::AdamWOptions&>(optimizer_->param_groups()[g].options())
        .lr(group_kinds_[g] == "backbone" ? record.lr_backbone : record.lr_heads);

  auto clock = std::chrono::steady_clock::now();
  const auto lap = [&](const char* phase) {
    const auto now = std::chrono::steady_clock::now();
    record.seconds[phase] = std::chrono::duration<double>(now - clock).count();
    clock = now;
  };
  const bool conditions = stage.stage >= 2;
  const TrainingBatch on_cpu = source_.batch(step_, conditions, rank_, world_size_);
  if (step_ + 1 < config_.total_steps())
    source_.prefetch(step_ + 1, config_.stages[stage_index(step_ + 1)].stage >= 2, rank_,
                     world_size_);
  const TrainingBatch batch = to_device(on_cpu, device_);
  record.images = batch.image.size(0) * world_size_;
  record.num_tokens = batch.num_tokens;
  record.width = batch.image.size(3);
  record.height = batch.image.size(2);
  lap("data");
  model_->train();
  const model::OmniPointOutput output = forward(batch, conditions);
  lap("forward");
  at::Generator generator = at::make_generator<at::CPUGeneratorImpl>(
      derived_seed(config_.seed, kLossStream, static_cast<uint64_t>(step_ * world_size_ + rank_)));
  const Losses losses = compute_losses(output, batch.targets, stage_loss(index), generator);
  lap("loss");
  for (const auto& [term, seconds] : losses.seconds) record.seconds["loss." + term] = seconds;
  record.loss = losses.total.item<double>();
  for (const auto& [name, term] : losses.terms) record.terms[name] = term.mean().item<double>();
  // Means over the ranks: one rank's non-finite loss makes every rank skip the step.
  record.loss = distributed_.all_reduce_mean(record.loss);
  record.terms = distributed_.all_reduce_mean(record.terms);

  optimizer_->zero_grad();
  bool finite = std::isfinite(record.loss);
  std::vector<at::Tensor> parameters;
  for (const auto& group : optimizer_->param_groups())
    for (const at::Tensor& p : group.params()) parameters.push_back(p);
  if (finite) {
    losses.total.backward();
    // A gradient missing on some ranks counts as zeros there (distributed.h), so the ranks
    // step exactly the parameters one process on the whole batch would step.
    distributed_.all_reduce_gradients(parameters);
    const double max_norm =
        config_.grad_clip > 0 ? config_.grad_clip : std::numeric_limits<double>::infinity();
    record.grad_norm = torch::nn::utils::clip_grad_norm_(parameters, max_norm);
    finite = std::isfinite(record.grad_norm);
  }
  lap("backward");
  if (finite) {
    optimizer_->step();
    at::NoGradGuard no_grad;
    for (const auto& [name, tensor] : model::state_dict(*model_)) {
      at::Tensor& average = ema_.at(name);
      if (average.is_floating_point())
        average.mul_(config_.ema_decay).add_(tensor, 1.0 - config_.ema_decay);
      else
        average.copy_(tensor);
    }
    consecutive_nonfinite_ = 0;
  } else {
    optimizer_->zero_grad();
    record.skipped = true;
    if (++consecutive_nonfinite_ >= config_.max_nonfinite_steps)
      throw std::runtime_error(
          "training stopped at step " + std::to_string(step_ + 1) + ": " +
          std::to_string(consecutive_nonfinite_) +
          " steps in a row had a non-finite loss or gradients (max_nonfinite_steps)");
  }
  lap("optimizer");
  record.step = ++step_;
  return record;
}

std::map<std::string, double> Trainer::evaluate() {
  at::NoGradGuard no_grad;
  // The EMA weights are what a run saves and ships, so they are what is scored: swapped in
  // for the evaluation and the live weights back afterwards (also when it throws).
  struct EmaWeights {
    std::map<std::string, at::Tensor> live, weights;
    EmaWeights(model::OmniPointModel& network, const std::map<std::string, at::Tensor>& ema)
        : weights(model::state_dict(*network)) {
      for (auto& [name, tensor] : weights) {
        live[name] = tensor.clone();
        tensor.copy_(ema.at(name));
      }
    }
    ~EmaWeights() {
      for (auto& [name, tensor] : weights) tensor.copy_(live.at(name));
    }
    EmaWeights(const EmaWeights&) = delete;
    EmaWeights& operator=(const EmaWeights&) = delete;
  } ema_weights(model_, ema_);
  const int index = stage_index(std::max<int64_t>(step_ - 1, 0));
  const bool conditions = config_.stages[index].stage >= 2;
  std::map<std::string, double> sums, counts;
  for (int64_t b = 0; b < config_.eval_batches; ++b) {
    // Batch b from bucket b (modulo their number), so that every aspect ratio is scored.
    // Scored on the CPU (eval/metrics.h), the network and the losses on the device.
    const BatchSource& source = eval_source_ ? *eval_source_ : source_;
    const TrainingBatch batch = source.batch(b, conditions, rank_, world_size_, kEvalStream, b);
    const TrainingBatch on_device = to_device(batch, device_);
    const model::OmniPointOutput output = forward(on_device, conditions);
    at::Generator generator =
        at::make_generator<at::CPUGeneratorImpl>(derived_seed(config_.seed, kEvalStream, b));
    const Losses losses = compute_losses(output, on_device.targets, config_.loss, generator);
    sums["loss"] += losses.total.item<double>();
    for (const auto& [name, term] : losses.terms) sums[name] += term.mean().item<double>();
    // The benchmark's scores (eval/metrics.h) on the same items: scale-invariant points and
    // metric points (metric items only), Rel and δ1 averaged over the items that have them.
    for (int64_t k = 0; k < batch.image.size(0); ++k) {
      const at::Tensor mask = batch.targets.mask[k];
      if (!mask.any().item<bool>()) continue;
      eval::GroundTruth truth;
      truth.points = batch.targets.distance[k].unsqueeze(-1) * batch.targets.rays[k];
      truth.depth = batch.targets.distance[k];
      truth.mask = mask;
      truth.is_metric = batch.targets.metric[k].item<bool>();
      eval::Prediction prediction;
      prediction.points = output.points[k].to(at::kCPU, at::kFloat);
      prediction.depth = prediction.points.norm(2, -1);
      prediction.is_metric = true;
      const eval::Metrics metrics = eval::compute_metrics(prediction, truth);
      for (const auto& [entry, key] :
           {std::pair{"points_scale_invariant", "points"}, {"points_metric", "metric"}}) {
        const auto found = metrics.entries.find(entry);
        if (found == metrics.entries.end() || !std::isfinite(found->second.rel)) continue;
        sums[std::string(key) + "_rel"] += found->second.rel;
        sums[std::string(key) + "_delta1"] += found->second.delta1;
        counts[std::string(key) + "_rel"] += 1, counts[std::string(key) + "_delta1"] += 1;
      }
    }
  }
  for (auto& [name, sum] : sums) {
    const auto counted = counts.find(name);
    sum /= counted != counts.end() ? counted->second : static_cast<double>(config_.eval_batches);
  }
  return distributed_.all_reduce_mean(sums);
}

TrainState Trainer::state() const {
  TrainState state;
  for (const auto& [name, tensor] : model::state_dict(*model_))
    state.model[name] = tensor.to(at::kCPU).clone();
  for (const auto& [name, tensor] : ema_) state.ema[name] = tensor.to(at::kCPU).clone();
  if (optimizer_) {
    const auto& params_state = optimizer_->state();
    for (size_t g = 0; g < group_names_.size(); ++g) {
      const auto& params = optimizer_->param_groups()[g].params();
      for (size_t i = 0; i < params.size(); ++i) {
        const auto found = params_state.find(state_key(params[i]));
        if (found == params_state.end()) continue;
        const auto& adam = static_cast<const torch::optim::AdamWParamState&>(*found->second);
        const std::string& name = group_names_[g][i];
        state.optimizer[name + ".exp_avg"] = adam.exp_avg().to(at::kCPU).clone();
        state.optimizer[name + ".exp_avg_sq"] = adam.exp_avg_sq().to(at::kCPU).clone();
        state.optimizer[name + ".step"] = at::full({1}, adam.step(), at::kLong);
      }
    }
  }
  {
    at::Generator generator = at::detail::getDefaultCPUGenerator();
    std::lock_guard<std::mutex> lock(generator.mutex());
    state.rng["torch_cpu"] = generator.get_state();
  }
  state.progress = {{"step", step_},
                    {"consecutive_nonfinite", consecutive_nonfinite_},
                    {"optimizer_stage", current_stage_}};
  return state;
}

void Trainer::restore(const TrainState& state) {
  try {
    model::load_state_dict(*model_, state.model, model::LoadMode::kStrict);
  } catch (const std::runtime_error& error) {
    throw std::invalid_argument(std::string("resume: the checkpoint's model does not fit: ") +
                                error.what());
  }
  for (auto& [name, average] : ema_) {
    const auto found = state.ema.find(name);
    if (found == state.ema.end() || found->second.sizes() != average.sizes())
      throw std::invalid_argument("resume: the checkpoint's EMA lacks \"" + name +
                                  "\" or has another shape");
    at::NoGradGuard no_grad;
    average.copy_(found->second);
  }
  const int64_t step = state.progress.at("step").get<int64_t>();
  if (step < 0 || step > config_.total_steps())
    throw std::invalid_argument("resume: the checkpoint is at step " + std::to_string(step) +
                                ", beyond this config's " + std::to_string(config_.total_steps()) +
                                " steps");
  step_ = step;
  consecutive_nonfinite_ = state.progress.at("consecutive_nonfinite").get<int64_t>();
  const int saved_stage = state.progress.at("optimizer_stage").get<int>();
  current_stage_ = -1;
  optimizer_.reset();
  if (saved_stage >= 0 && saved_stage == stage_index(step_) && !done()) {
    configure_stage(saved_stage);
    auto& params_state = optimizer_->state();
    for (size_t g = 0; g < group_names_.size(); ++g) {
      const auto& params = optimizer_->param_groups()[g].params();
      for (size_t i = 0; i < params.size(); ++i) {
        const std::string& name = group_names_[g][i];
        const auto avg = state.optimizer.find(name + ".exp_avg");
        if (avg == state.optimizer.end()) continue;
        auto adam = std::make_unique<torch::optim::AdamWParamState>();
        adam->step(state.optimizer.at(name + ".step").item<int64_t>());
        adam->exp_avg(avg->second.to(params[i].options()).clone());
        adam->exp_avg_sq(state.optimizer.at(name + ".exp_avg_sq").to(params[i].options()).clone());
        params_state[state_key(params[i])] = std::move(adam);
      }
    }
  }
  const auto rng = state.rng.find("torch_cpu");
  if (rng != state.rng.end()) {
    at::Generator generator = at::detail::getDefaultCPUGenerator();
    std::lock_guard<std::mutex> lock(generator.mutex());
    generator.set_state(rng->second);
  }
}

}  // namespace omnipoint::train
