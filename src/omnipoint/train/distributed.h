#pragma once
// Data-parallel training on PyTorch's c10d process groups (Gloo on CPU, NCCL on CUDA when
// LibTorch was built with it).
//
// Ranks and rendezvous come from the environment variables that torchrun, SLURM wrappers and
// `omnipoint train --nproc N` (launcher.h) set: RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR,
// MASTER_PORT. WORLD_SIZE unset or 1 gives a single-process context whose operations do
// nothing, so the trainer calls them unconditionally. Rank 0 hosts the c10d::TCPStore at
// MASTER_ADDR:MASTER_PORT; the other ranks connect to it.
//
// Every collective must be called by all ranks in the same order with tensors of the same
// shapes and dtypes (c10d's contract); gradients are averaged, so each rank's loss must be
// the mean over its own equal share of the global batch.
#include <ATen/core/Tensor.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace torch::nn {
class Module;
}

namespace omnipoint::train {

struct DistributedEnv {
  int rank = 0;
  int world_size = 1;
  int local_rank = 0;       // LOCAL_RANK, 0 when unset: the process's index on its machine
  std::string master_addr;  // required when world_size > 1
  int master_port = 0;      // required when world_size > 1
};

// Reads the variables through `lookup` (nullopt = unset). std::invalid_argument naming the
// variable for a non-integer or out-of-range value, RANK >= WORLD_SIZE, or a missing
// RANK / MASTER_ADDR / MASTER_PORT when WORLD_SIZE > 1.
DistributedEnv parse_distributed_env(
    const std::function<std::optional<std::string>(const std::string&)>& lookup);
// The same, from this process's environment.
DistributedEnv distributed_env_from_process();

struct DistributedOptions {
  // Rendezvous and every collective fail with std::runtime_error after this long.
  std::chrono::milliseconds timeout = std::chrono::minutes(5);
  // Gradients are all-reduced in flat buckets of about this many bytes (PyTorch DDP's 25 MB).
  int64_t bucket_bytes = int64_t{25} * 1024 * 1024;
  // NCCL for CUDA tensors (only where LibTorch has it, else std::invalid_argument); Gloo otherwise.
  bool cuda = false;
};

class DistributedContext {
 public:
  // One process: every operation is a no-op.
  DistributedContext();
  // Joins the process group that `env` describes (a no-op context when world_size == 1).
  // std::runtime_error naming MASTER_ADDR:MASTER_PORT when the rendezvous fails or times out.
  explicit DistributedContext(const DistributedEnv& env, DistributedOptions options = {});
  ~DistributedContext();
  DistributedContext(DistributedContext&&) noexcept;
  DistributedContext& operator=(DistributedContext&&) noexcept;

  static DistributedContext from_environment(DistributedOptions options = {}) {
    return DistributedContext(distributed_env_from_process(), options);
  }

  int rank() const { return env_.rank; }
  int world_size() const { return env_.world_size; }
  int local_rank() const { return env_.local_rank; }
  bool active() const { return env_.world_size > 1; }
  // Only the main rank writes checkpoints and logs.
  bool is_main() const { return env_.rank == 0; }

  // Copies rank 0's values into `tensors` on every rank (in place, bucketed).
  void broadcast_(const std::vector<at::Tensor>& tensors) const;
  // Rank 0's parameters and buffers into every rank's module: call once before training.
  void broadcast_module(const torch::nn::Module& module) const;

  // Replaces each tensor by its mean over the ranks, in place: one all-reduce per bucket of
  // ~bucket_bytes of tensors of one dtype and device. Returns the number of all-reduces.
  int64_t all_reduce_mean_(const std::vector<at::Tensor>& tensors) const;
  // Averages the gradients of `parameters`. A parameter whose gradient is undefined on some
  // ranks gets zeros there first (it contributed nothing to their loss); one whose gradient
  // is undefined on every rank stays undefined, so the optimiser still skips it.
  void all_reduce_gradients(const std::vector<at::Tensor>& parameters) const;

  // Means over the ranks of per-rank scalars (losses, metrics), for logging.
  std::vector<double> all_reduce_mean(const std::vector<double>& values) const;
  double all_reduce_mean(double value) const {
    return all_reduce_mean(std::vector<double>{value})[0];
  }
  // Keys must be the same on every rank.
  std::map<std::string, double> all_reduce_mean(const std::map<std::string, double>& values) const;

  // Whether `value` is true on every rank, e.g. a finite loss: a step is skipped everywhere or
  // nowhere, so that the ranks keep calling the same collectives.
  bool all_true(bool value) const;

  // Returns when every rank has called it.
  void barrier() const;

 private:
  struct Group;
  DistributedEnv env_;
  DistributedOptions options_;
  std::unique_ptr<Group> group_;
};

// Indices of `tensors` per all-reduce bucket: tensors of one dtype and device in their order,
// a new bucket once the next tensor would exceed `bucket_bytes` (a larger tensor is alone).
std::vector<std::vector<size_t>> plan_buckets(const std::vector<at::Tensor>& tensors,
                                              int64_t bucket_bytes);

// This rank's items of a deterministic order of `count` items: rank, rank + W, rank + 2W, ...
std::vector<int64_t> shard_indices(int64_t count, int rank, int world_size);

}  // namespace omnipoint::train
