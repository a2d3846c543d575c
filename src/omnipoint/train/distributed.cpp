#include "omnipoint/train/distributed.h"

#include <ATen/ATen.h>
#include <torch/nn/module.h>
#include <torch/csrc/distributed/c10d/ProcessGroup.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

// Each process group needs LibTorch built with it and its headers (found by CMake).
#if defined(USE_C10D_GLOO) && defined(OMNIPOINT_HAVE_GLOO_HEADERS)
#define OMNIPOINT_GLOO
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#endif
#if defined(USE_C10D_NCCL) && defined(OMNIPOINT_HAVE_NCCL_HEADERS)
#define OMNIPOINT_NCCL
#include <torch/csrc/distributed/c10d/ProcessGroupNCCL.hpp>
#endif

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

namespace omnipoint::train {
namespace {

// A whole decimal integer in [low, high], or std::invalid_argument naming the variable.
int parse_env_int(const std::string& name, const std::string& text, int low, int high) {
  const std::string expected =
      "expected an integer in [" + std::to_string(low) + ", " + std::to_string(high) + "]";
  size_t used = 0;
  long long value = 0;
  try {
    value = std::stoll(text, &used);
  } catch (const std::exception&) {
    throw std::invalid_argument("environment variable " + name + "='" + text + "': " + expected);
  }
  if (used != text.size() || value < low || value > high)
    throw std::invalid_argument("environment variable " + name + "='" + text + "': " + expected);
  return static_cast<int>(value);
}

#ifdef OMNIPOINT_GLOO
bool is_loopback(const std::string& address) {
  return address == "localhost" || address.rfind("127.", 0) == 0 || address == "::1";
}
#endif

// Runs `collective` on each bucket of `tensors`: flatten, collective, copy back.
template <class Collective>
int64_t run_bucketed(const std::vector<at::Tensor>& tensors, int64_t bucket_bytes,
                     Collective collective) {
  at::NoGradGuard no_grad;
  const auto buckets = plan_buckets(tensors, bucket_bytes);
  for (const auto& bucket : buckets) {
    if (bucket.size() == 1 && tensors[bucket[0]].is_contiguous()) {  // a large tensor: no copies
      at::Tensor alone = tensors[bucket[0]];
      collective(alone);
      continue;
    }
    std::vector<at::Tensor> flat_parts;
    flat_parts.reserve(bucket.size());
    for (size_t i : bucket) flat_parts.push_back(tensors[i].reshape(-1));
    at::Tensor flat = at::cat(flat_parts);
    collective(flat);
    int64_t offset = 0;
    for (size_t i : bucket) {
      const at::Tensor& tensor = tensors[i];
      tensor.copy_(flat.narrow(0, offset, tensor.numel()).view(tensor.sizes()));
      offset += tensor.numel();
    }
  }
  return static_cast<int64_t>(buckets.size());
}

}  // namespace

DistributedEnv parse_distributed_env(
    const std::function<std::optional<std::string>(const std::string&)>& lookup) {
  constexpr int kMaxWorld = 1 << 20;
  DistributedEnv env;
  if (const auto world = lookup("WORLD_SIZE"))
    env.world_size = parse_env_int("WORLD_SIZE", *world, 1, kMaxWorld);
  const auto rank = lookup("RANK");
  if (rank) {
    env.rank = parse_env_int("RANK", *rank, 0, kMaxWorld);
    if (env.rank >= env.world_size)
      throw std::invalid_argument(
          "environment variable RANK=" + *rank +
          ": expected a rank below WORLD_SIZE=" + std::to_string(env.world_size));
  }
  if (const auto local = lookup("LOCAL_RANK"))
    env.local_rank = parse_env_int("LOCAL_RANK", *local, 0, kMaxWorld);
  if (env.world_size == 1) return env;

  if (!rank)
    throw std::invalid_argument(
        "environment variable RANK is not set: expected it with WORLD_SIZE=" +
        std::to_string(env.world_size));
  const auto addr = lookup("MASTER_ADDR");
  if (!addr || addr->empty())
    throw std::invalid_argument(
        "environment variable MASTER_ADDR is not set: expected the host of rank 0 with "
        "WORLD_SIZE=" +
        std::to_string(env.world_size));
  env.master_addr = *addr;
  const auto port = lookup("MASTER_PORT");
  if (!port)
    throw std::invalid_argument(
        "environment variable MASTER_PORT is not set: expected rank 0's port with WORLD_SIZE=" +
        std::to_string(env.world_size));
  env.master_port = parse_env_int("MASTER_PORT", *port, 1, 65535);
  return env;
}

DistributedEnv distributed_env_from_process() {
  return parse_distributed_env([](const std::string& name) -> std::optional<std::string> {
    const char* value = std::getenv(name.c_str());
    if (value == nullptr) return std::nullopt;
    return std::string(value);
  });
}

struct DistributedContext::Group {
  c10::intrusive_ptr<c10d::Store> store;
  c10::intrusive_ptr<c10d::ProcessGroup> process_group;
};

DistributedContext::DistributedContext() = default;
DistributedContext::~DistributedContext() = default;
DistributedContext::DistributedContext(DistributedContext&&) noexcept = default;
DistributedContext& DistributedContext::operator=(DistributedContext&&) noexcept = default;

DistributedContext::DistributedContext(const DistributedEnv& env, DistributedOptions options)
    : env_(env), options_(options) {
  if (env.world_size < 1 || env.rank < 0 || env.rank >= env.world_size)
    throw std::invalid_argument("distributed: rank " + std::to_string(env.rank) +
                                " of world size " + std::to_string(env.world_size) +
                                ": expected 0 <= rank < world size");
  if (options.bucket_bytes <= 0)
    throw std::invalid_argument("distributed: bucket_bytes must be positive");
  if (!active()) return;
#ifndef OMNIPOINT_NCCL
  if (options.cuda)
    throw std::invalid_argument(
        "distributed: CUDA training on more than one process needs the NCCL process group, "
        "which this build left out (LibTorch 2, or no NCCL or nccl.h)");
#endif
#ifndef OMNIPOINT_GLOO
  if (!options.cuda)
    throw std::invalid_argument(
        "distributed: CPU training on more than one process needs the Gloo process group, "
        "which this build left out (LibTorch 2, or no Gloo or gloo headers: Debian libgloo-dev)");
#endif

  const std::string master = env.master_addr + ":" + std::to_string(env.master_port);
  group_ = std::make_unique<Group>();
  try {
    c10d::TCPStoreOptions store_options;
    store_options.port = static_cast<std::uint16_t>(env.master_port);
    store_options.isServer = env.rank == 0;
    store_options.numWorkers = static_cast<std::size_t>(env.world_size);
    store_options.waitWorkers = true;
    store_options.timeout = options.timeout;
    group_->store = c10::make_intrusive<c10d::TCPStore>(env.master_addr, store_options);
  } catch (const std::exception& error) {
    const std::string failure =
        env.rank == 0 ? " could not host the rendezvous for " + std::to_string(env.world_size) +
                            " ranks at MASTER_ADDR:MASTER_PORT="
                      : " could not reach the rendezvous at MASTER_ADDR:MASTER_PORT=";
    throw std::runtime_error("distributed: rank " + std::to_string(env.rank) + failure + master +
                             " within " + std::to_string(options.timeout.count()) +
                             " ms: " + error.what());
  }
  try {
#ifdef OMNIPOINT_NCCL
    if (options.cuda) {
      auto nccl_options = c10d::ProcessGroupNCCL::Options::create();
      nccl_options->timeout = options.timeout;
      group_->process_group = c10::make_intrusive<c10d::ProcessGroupNCCL>(
          group_->store, env.rank, env.world_size, nccl_options);
      return;
    }
#endif
#ifdef OMNIPOINT_GLOO
    auto gloo_options = c10d::ProcessGroupGloo::Options::create();
    gloo_options->timeout = options.timeout;
    // GLOO_SOCKET_IFNAME picks the network interface as in PyTorch; a loopback master means
    // one machine, where the loopback interface always works.
    if (const char* interface = std::getenv("GLOO_SOCKET_IFNAME"))
      gloo_options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForInterface(interface));
    else if (is_loopback(env.master_addr))
      gloo_options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1"));
    else
      gloo_options->devices.push_back(c10d::ProcessGroupGloo::createDefaultDevice());
    group_->process_group = c10::make_intrusive<c10d::ProcessGroupGloo>(
        group_->store, env.rank, env.world_size, gloo_options);
#endif
  } catch (const std::exception& error) {
    throw std::runtime_error("distributed: rank " + std::to_string(env.rank) +
                             " could not join the process group at " + master + ": " +
                             error.what());
  }
}

void DistributedContext::broadcast_(const std::vector<at::Tensor>& tensors) const {
  if (!active()) return;
  run_bucketed(tensors, options_.bucket_bytes, [&](at::Tensor& flat) {
    std::vector<at::Tensor> list{flat};
    c10d::BroadcastOptions broadcast_options;
    broadcast_options.rootRank = 0;
    group_->process_group->broadcast(list, broadcast_options)->wait();
  });
}

void DistributedContext::broadcast_module(const torch::nn::Module& module) const {
  std::vector<at::Tensor> tensors = module.parameters();
  for (const at::Tensor& buffer : module.buffers()) tensors.push_back(buffer);
  broadcast_(tensors);
}

int64_t DistributedContext::all_reduce_mean_(const std::vector<at::Tensor>& tensors) const {
  if (!active()) return 0;
  for (const at::Tensor& tensor : tensors)
    if (!tensor.is_floating_point())
      throw std::invalid_argument("all_reduce_mean_: expected floating-point tensors, got " +
                                  std::string(c10::toString(tensor.scalar_type())));
  return run_bucketed(tensors, options_.bucket_bytes, [&](at::Tensor& flat) {
    std::vector<at::Tensor> list{flat};
    group_->process_group->allreduce(list)->wait();  // default: sum
    flat.div_(env_.world_size);
  });
}

void DistributedContext::all_reduce_gradients(const std::vector<at::Tensor>& parameters) const {
  if (!active()) return;
  // Which ranks have each gradient: one small all-reduce of flags.
  std::vector<float> defined;
  defined.reserve(parameters.size());
  for (const at::Tensor& parameter : parameters)
    defined.push_back(parameter.grad().defined() ? 1.0f : 0.0f);
  at::Tensor has_gradient = at::tensor(defined, at::kFloat);
  if (options_.cuda && !parameters.empty()) has_gradient = has_gradient.to(parameters[0].device());
  std::vector<at::Tensor> flags{has_gradient};
  group_->process_group->allreduce(flags)->wait();
  has_gradient = has_gradient.cpu();
  const float* ranks_with_gradient = has_gradient.data_ptr<float>();

  std::vector<at::Tensor> gradients;
  for (size_t i = 0; i < parameters.size(); ++i) {
    if (ranks_with_gradient[i] == 0) continue;
    at::Tensor parameter = parameters[i];
    if (!parameter.grad().defined()) parameter.mutable_grad() = at::zeros_like(parameter);
    gradients.push_back(parameter.grad());
  }
  all_reduce_mean_(gradients);
}

std::vector<double> DistributedContext::all_reduce_mean(const std::vector<double>& values) const {
  if (!active() || values.empty()) return values;
  at::Tensor flat = at::tensor(at::ArrayRef<double>(values), at::kDouble);
  if (options_.cuda) flat = flat.to(at::Device(at::kCUDA, env_.local_rank));
  std::vector<at::Tensor> list{flat};
  group_->process_group->allreduce(list)->wait();
  flat = flat.cpu().div_(env_.world_size);
  return std::vector<double>(flat.data_ptr<double>(), flat.data_ptr<double>() + flat.numel());
}

std::map<std::string, double> DistributedContext::all_reduce_mean(
    const std::map<std::string, double>& values) const {
  std::vector<double> flat;
  flat.reserve(values.size());
  for (const auto& [name, value] : values) flat.push_back(value);
  flat = all_reduce_mean(flat);
  std::map<std::string, double> means;
  size_t i = 0;
  for (const auto& [name, value] : values) means[name] = flat[i++];
  return means;
}

bool DistributedContext::all_true(bool value) const {
  return all_reduce_mean(value ? 0.0 : 1.0) == 0.0;
}

void DistributedContext::barrier() const {
  if (!active()) return;
  group_->process_group->barrier()->wait();
}

std::vector<std::vector<size_t>> plan_buckets(const std::vector<at::Tensor>& tensors,
                                              int64_t bucket_bytes) {
  if (bucket_bytes <= 0) throw std::invalid_argument("plan_buckets: bucket_bytes must be positive");
  struct Open {
    at::ScalarType dtype;
    at::Device device;
    std::vector<size_t> members;
    int64_t bytes;
  };
  std::vector<Open> open;  // one filling bucket per (dtype, device)
  std::vector<std::vector<size_t>> buckets;
  for (size_t i = 0; i < tensors.size(); ++i) {
    const at::Tensor& tensor = tensors[i];
    if (!tensor.defined())
      throw std::invalid_argument("plan_buckets: tensor " + std::to_string(i) + " is undefined");
    const int64_t bytes = tensor.numel() * static_cast<int64_t>(tensor.element_size());
    auto slot = std::find_if(open.begin(), open.end(), [&](const Open& o) {
      return o.dtype == tensor.scalar_type() && o.device == tensor.device();
    });
    if (slot == open.end()) {
      open.push_back({tensor.scalar_type(), tensor.device(), {}, 0});
      slot = open.end() - 1;
    }
    if (!slot->members.empty() && slot->bytes + bytes > bucket_bytes) {
      buckets.push_back(std::move(slot->members));
      slot->members.clear();
      slot->bytes = 0;
    }
    slot->members.push_back(i);
    slot->bytes += bytes;
  }
  for (Open& o : open)
    if (!o.members.empty()) buckets.push_back(std::move(o.members));
  return buckets;
}

std::vector<int64_t> shard_indices(int64_t count, int rank, int world_size) {
  if (count < 0 || world_size < 1 || rank < 0 || rank >= world_size)
    throw std::invalid_argument(
        "shard_indices: expected count >= 0 and 0 <= rank < world_size, got count " +
        std::to_string(count) + ", rank " + std::to_string(rank) + ", world_size " +
        std::to_string(world_size));
  std::vector<int64_t> indices;
  for (int64_t i = rank; i < count; i += world_size) indices.push_back(i);
  return indices;
}

}  // namespace omnipoint::train
