#pragma once
// Data-parallel training on PyTorch's c10d process groups (Gloo, CPU tensors). Ranks and the
// rendezvous come from the usual environment variables, as torchrun and schedulers set them:
//   RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR (default 127.0.0.1), MASTER_PORT (default 29500);
// rank 0 hosts the c10d::TCPStore. Each rank trains on its shard of every global batch
// (batch_source.h) and the gradients are averaged by all-reduce in flat buckets before
// clipping and the optimiser step, so all ranks keep identical parameters.
#include <cstdint>
#include <memory>
#include <string>

#include "omnipoint/train/trainer.h"

namespace omnipoint::train {

class DataParallel {
 public:
  // nullptr when WORLD_SIZE is unset or 1. std::invalid_argument for inconsistent variables,
  // std::runtime_error when this build has no Gloo or the rendezvous fails.
  static std::unique_ptr<DataParallel> from_environment();
  ~DataParallel();

  int64_t rank() const { return rank_; }
  int64_t world_size() const { return world_size_; }
  // Averages gradients across ranks in place (buckets of at most 25 MB).
  GradientReducer reducer();
  void barrier();

 private:
  struct Group;
  DataParallel(int64_t rank, int64_t world_size, std::unique_ptr<Group> group);
  int64_t rank_, world_size_;
  std::shared_ptr<Group> group_;
};

}  // namespace omnipoint::train
