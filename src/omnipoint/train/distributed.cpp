#include "omnipoint/train/distributed.h"

#include <ATen/ATen.h>

#include <cstdlib>
#include <stdexcept>
#include <vector>

#ifdef OMNIPOINT_WITH_GLOO
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#endif

namespace omnipoint::train {
namespace {

int64_t env_int(const char* name, int64_t fallback) {
  const char* value = std::getenv(name);
  if (value == nullptr || *value == '\0') return fallback;
  try {
    size_t used = 0;
    const int64_t parsed = std::stoll(value, &used);
    if (used == std::string(value).size()) return parsed;
  } catch (const std::exception&) {
  }
  throw std::invalid_argument(std::string("environment variable ") + name + "=\"" + value + "\": expected an integer");
}

std::string env_text(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : fallback;
}

constexpr int64_t kBucketBytes = 25 << 20;

}  // namespace

#ifdef OMNIPOINT_WITH_GLOO
struct DataParallel::Group {
  c10::intrusive_ptr<c10d::ProcessGroupGloo> process_group;
};
#else
struct DataParallel::Group {};
#endif

DataParallel::DataParallel(int64_t rank, int64_t world_size, std::unique_ptr<Group> group)
    : rank_(rank), world_size_(world_size), group_(std::move(group)) {}

DataParallel::~DataParallel() = default;

std::unique_ptr<DataParallel> DataParallel::from_environment() {
  const int64_t world_size = env_int("WORLD_SIZE", 1);
  if (world_size <= 1) return nullptr;
  const int64_t rank = env_int("RANK", -1);
  if (rank < 0 || rank >= world_size)
    throw std::invalid_argument("environment variable RANK: expected 0 <= RANK < WORLD_SIZE=" +
                                std::to_string(world_size));
  const int64_t port = env_int("MASTER_PORT", 29500);
  if (port <= 0 || port > 65535) throw std::invalid_argument("environment variable MASTER_PORT: expected a TCP port");
#ifdef OMNIPOINT_WITH_GLOO
  const std::string address = env_text("MASTER_ADDR", "127.0.0.1");
  c10d::TCPStoreOptions store_options;
  store_options.port = static_cast<std::uint16_t>(port);
  store_options.isServer = rank == 0;
  store_options.numWorkers = static_cast<std::size_t>(world_size);
  auto group = std::make_unique<Group>();
  try {
    auto store = c10::make_intrusive<c10d::TCPStore>(address, store_options);
    auto options = c10d::ProcessGroupGloo::Options::create();
    options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname(address));
    group->process_group = c10::make_intrusive<c10d::ProcessGroupGloo>(store, static_cast<int>(rank),
                                                                      static_cast<int>(world_size), options);
  } catch (const std::exception& e) {
    throw std::runtime_error("distributed rendezvous at " + address + ":" + std::to_string(port) + " failed: " + e.what());
  }
  return std::unique_ptr<DataParallel>(new DataParallel(rank, world_size, std::move(group)));
#else
  throw std::runtime_error("distributed training (WORLD_SIZE=" + std::to_string(world_size) +
                           "): not available, this build has no Gloo (install libgloo-dev and rebuild)");
#endif
}

GradientReducer DataParallel::reducer() {
  std::shared_ptr<Group> group = group_;
  const double world = static_cast<double>(world_size_);
  return [group, world](const std::vector<at::Tensor>& gradients) {
#ifdef OMNIPOINT_WITH_GLOO
    size_t begin = 0;
    while (begin < gradients.size()) {
      // One bucket: consecutive gradients of one dtype up to kBucketBytes, flattened.
      size_t end = begin;
      int64_t bytes = 0;
      while (end < gradients.size() && gradients[end].scalar_type() == gradients[begin].scalar_type() &&
             (end == begin || bytes + static_cast<int64_t>(gradients[end].nbytes()) <= kBucketBytes))
        bytes += static_cast<int64_t>(gradients[end++].nbytes());
      std::vector<at::Tensor> flat_parts;
      for (size_t i = begin; i < end; ++i) flat_parts.push_back(gradients[i].reshape({-1}));
      std::vector<at::Tensor> bucket{at::cat(flat_parts)};
      group->process_group->allreduce(bucket)->wait();
      bucket[0].div_(world);
      int64_t offset = 0;
      for (size_t i = begin; i < end; ++i) {
        const int64_t n = gradients[i].numel();
        gradients[i].copy_(bucket[0].narrow(0, offset, n).view_as(gradients[i]));
        offset += n;
      }
      begin = end;
    }
#else
    (void)group;
    (void)world;
    (void)gradients;
#endif
  };
}

void DataParallel::barrier() {
#ifdef OMNIPOINT_WITH_GLOO
  group_->process_group->barrier()->wait();
#endif
}

}  // namespace omnipoint::train
