// Data-parallel training over c10d Gloo on localhost. Collective tests run each rank in a
// thread with its own TCPStore client and ProcessGroupGloo; the end-to-end test starts two
// processes of this binary through launch_local (they run DistributedWorker.TrainOnShard).
#include <gtest/gtest.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/linear.h>
#include <torch/optim/sgd.h>

#include <ATen/ATen.h>

#include <chrono>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <thread>

#include "omnipoint/io/npy.h"
#include "omnipoint/train/distributed.h"
#include "omnipoint/train/launcher.h"

namespace omnipoint::train {
namespace {

using Env = std::map<std::string, std::string>;

DistributedEnv parse(const Env& variables) {
  return parse_distributed_env([&](const std::string& name) -> std::optional<std::string> {
    auto it = variables.find(name);
    if (it == variables.end()) return std::nullopt;
    return it->second;
  });
}

// The message of the std::invalid_argument that parsing `variables` throws ("" if none).
std::string parse_error(const Env& variables) {
  try {
    parse(variables);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

DistributedOptions test_options(int64_t bucket_bytes = int64_t{25} * 1024 * 1024) {
  DistributedOptions options;
  options.timeout = std::chrono::seconds(30);
  options.bucket_bytes = bucket_bytes;
  return options;
}

// Runs body(context) on `world` ranks, one thread each, joined over a fresh localhost port.
template <class Body>
void run_ranks(int world, const DistributedOptions& options, Body body) {
  const int port = free_port();
  std::vector<std::exception_ptr> errors(world);
  std::vector<std::thread> threads;
  for (int rank = 0; rank < world; ++rank) {
    threads.emplace_back([&, rank] {
      try {
        DistributedContext context(DistributedEnv{rank, world, rank, "127.0.0.1", port}, options);
        body(context);
      } catch (...) {
        errors[rank] = std::current_exception();
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const std::exception_ptr& error : errors)
    if (error) std::rethrow_exception(error);
}

TEST(DistributedEnvTest, UnsetOrWorldOneIsOneProcess) {
  const DistributedEnv unset = parse({});
  EXPECT_EQ(unset.world_size, 1);
  EXPECT_EQ(unset.rank, 0);
  EXPECT_FALSE(DistributedContext(unset).active());
  const DistributedEnv one = parse({{"WORLD_SIZE", "1"}, {"RANK", "0"}});
  EXPECT_EQ(one.world_size, 1);
}

TEST(DistributedEnvTest, ReadsTheTorchrunVariables) {
  const DistributedEnv env = parse({{"RANK", "3"},
                                    {"WORLD_SIZE", "8"},
                                    {"LOCAL_RANK", "1"},
                                    {"MASTER_ADDR", "node0"},
                                    {"MASTER_PORT", "29500"}});
  EXPECT_EQ(env.rank, 3);
  EXPECT_EQ(env.world_size, 8);
  EXPECT_EQ(env.local_rank, 1);
  EXPECT_EQ(env.master_addr, "node0");
  EXPECT_EQ(env.master_port, 29500);
}

TEST(DistributedEnvTest, BadValuesNameTheVariable) {
  const Env good = {
      {"RANK", "1"}, {"WORLD_SIZE", "2"}, {"MASTER_ADDR", "127.0.0.1"}, {"MASTER_PORT", "29500"}};
  ASSERT_EQ(parse_error(good), "");
  auto with = [&](const std::string& name, const std::string& value) {
    Env variables = good;
    variables[name] = value;
    return parse_error(variables);
  };
  auto without = [&](const std::string& name) {
    Env variables = good;
    variables.erase(name);
    return parse_error(variables);
  };
  EXPECT_NE(with("RANK", "one").find("RANK='one'"), std::string::npos);
  EXPECT_NE(with("RANK", "1.5").find("RANK='1.5'"), std::string::npos);
  EXPECT_NE(with("RANK", "-1").find("RANK"), std::string::npos);
  EXPECT_NE(with("RANK", "2").find("below WORLD_SIZE=2"), std::string::npos);
  EXPECT_NE(with("WORLD_SIZE", "0").find("WORLD_SIZE='0'"), std::string::npos);
  EXPECT_NE(with("WORLD_SIZE", "").find("WORLD_SIZE"), std::string::npos);
  EXPECT_NE(with("LOCAL_RANK", "x").find("LOCAL_RANK"), std::string::npos);
  EXPECT_NE(with("MASTER_PORT", "70000").find("MASTER_PORT='70000'"), std::string::npos);
  EXPECT_NE(without("RANK").find("RANK is not set"), std::string::npos);
  EXPECT_NE(without("MASTER_ADDR").find("MASTER_ADDR is not set"), std::string::npos);
  EXPECT_NE(without("MASTER_PORT").find("MASTER_PORT is not set"), std::string::npos);
  EXPECT_THROW(DistributedContext(DistributedEnv{2, 2, 0, "127.0.0.1", 1}), std::invalid_argument);
}

TEST(DistributedContextTest, UnreachableMasterFailsAfterTheTimeout) {
  const int port = free_port();  // nobody listens there
  DistributedOptions options;
  options.timeout = std::chrono::milliseconds(1500);
  const auto start = std::chrono::steady_clock::now();
  try {
    [[maybe_unused]] const DistributedContext context(DistributedEnv{1, 2, 1, "127.0.0.1", port},
                                                      options);
    FAIL() << "joined a process group without a master";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("127.0.0.1:" + std::to_string(port)),
              std::string::npos)
        << error.what();
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
}

TEST(DistributedContextTest, MasterAloneFailsAfterTheTimeout) {
  const int port = free_port();
  DistributedOptions options;
  options.timeout = std::chrono::milliseconds(1000);
  try {
    [[maybe_unused]] const DistributedContext context(DistributedEnv{0, 2, 0, "127.0.0.1", port},
                                                      options);
    FAIL() << "joined a process group of 2 alone";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("127.0.0.1:" + std::to_string(port)),
              std::string::npos)
        << error.what();
  }
}

TEST(DistributedContextTest, RanksMayStartBeforeTheMaster) {
  const int port = free_port();
  std::exception_ptr late_error;
  std::thread early([&] {
    try {
      DistributedContext(DistributedEnv{1, 2, 1, "127.0.0.1", port}, test_options()).barrier();
    } catch (...) {
      late_error = std::current_exception();
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  DistributedContext(DistributedEnv{0, 2, 0, "127.0.0.1", port}, test_options()).barrier();
  early.join();
  if (late_error) std::rethrow_exception(late_error);
}

TEST(DistributedContextTest, OneProcessOperationsDoNothing) {
  const DistributedContext context;
  EXPECT_TRUE(context.is_main());
  EXPECT_FALSE(context.active());
  at::Tensor x = at::arange(4, at::kFloat);
  EXPECT_EQ(context.all_reduce_mean_({x}), 0);
  EXPECT_TRUE(x.equal(at::arange(4, at::kFloat)));
  EXPECT_EQ(context.all_reduce_mean(2.5), 2.5);
  EXPECT_FALSE(context.all_true(false));
  context.barrier();
}

TEST(ShardTest, RanksTakeStridedDisjointItems) {
  EXPECT_EQ(shard_indices(10, 1, 3), (std::vector<int64_t>{1, 4, 7}));
  EXPECT_EQ(shard_indices(2, 2, 3), (std::vector<int64_t>{}));
  std::vector<int> seen(11, 0);
  for (int rank = 0; rank < 4; ++rank)
    for (int64_t i : shard_indices(11, rank, 4)) ++seen[static_cast<size_t>(i)];
  EXPECT_EQ(seen, std::vector<int>(11, 1));
  EXPECT_THROW(shard_indices(4, 2, 2), std::invalid_argument);
  EXPECT_THROW(shard_indices(4, 0, 0), std::invalid_argument);
}

// 50 small float tensors (40 bytes each), one of 4 MB, 10 doubles; 1000-byte buckets.
std::vector<at::Tensor> mixed_tensors(double scale) {
  std::vector<at::Tensor> tensors;
  for (int i = 0; i < 50; ++i) tensors.push_back(at::full({2, 5}, scale * i, at::kFloat));
  tensors.push_back(at::arange(1 << 20, at::kFloat).mul_(scale));
  for (int i = 0; i < 10; ++i) tensors.push_back(at::full({10}, scale * (i + 0.25), at::kDouble));
  return tensors;
}

std::vector<size_t> range(size_t begin, size_t end) {
  std::vector<size_t> indices;
  for (size_t i = begin; i < end; ++i) indices.push_back(i);
  return indices;
}

TEST(BucketTest, SmallTensorsShareBucketsALargeOneIsAloneDtypesApart) {
  const auto buckets = plan_buckets(mixed_tensors(1.0), 1000);
  ASSERT_EQ(buckets.size(), 4u);
  EXPECT_EQ(buckets[0], range(0, 25));
  EXPECT_EQ(buckets[1], range(25, 50));
  EXPECT_EQ(buckets[2], range(50, 51));
  EXPECT_EQ(buckets[3], range(51, 61));
  EXPECT_THROW(plan_buckets({at::Tensor()}, 1000), std::invalid_argument);
}

TEST(BucketTest, AllReduceAveragesEveryTensorInPlace) {
  run_ranks(2, test_options(1000), [](const DistributedContext& context) {
    std::vector<at::Tensor> tensors = mixed_tensors(context.rank() + 1.0);  // ranks: x1 and x2
    at::Tensor strided = at::arange(6, at::kFloat).reshape({2, 3}).t().mul(context.rank() + 1.0);
    tensors.push_back(strided);
    EXPECT_EQ(context.all_reduce_mean_(tensors),
              5);  // the 4 planned above, then the large one is full
    const std::vector<at::Tensor> expected = mixed_tensors(1.5);
    for (size_t i = 0; i < expected.size(); ++i)
      EXPECT_TRUE(tensors[i].allclose(expected[i], 0, 1e-6)) << i;
    EXPECT_TRUE(strided.equal(at::arange(6, at::kFloat).reshape({2, 3}).t().mul(1.5)));
    EXPECT_THROW(context.all_reduce_mean_({at::arange(3)}), std::invalid_argument);
  });
}

TEST(BucketTest, ParametersWithoutGradientOnSomeOrAllRanks) {
  run_ranks(2, test_options(), [](const DistributedContext& context) {
    const double scale = context.rank() + 1.0;
    at::Tensor both = at::zeros({3}).requires_grad_(), only_rank0 = at::zeros({2}).requires_grad_(),
               none = at::zeros({4}).requires_grad_();
    both.mutable_grad() = at::full({3}, scale);
    if (context.rank() == 0) only_rank0.mutable_grad() = at::full({2}, 4.0);
    context.all_reduce_gradients({both, only_rank0, none});
    EXPECT_TRUE(both.grad().equal(at::full({3}, 1.5)));
    ASSERT_TRUE(only_rank0.grad().defined());
    EXPECT_TRUE(only_rank0.grad().equal(at::full({2}, 2.0)));
    EXPECT_FALSE(none.grad().defined());
  });
}

TEST(DistributedContextTest, ScalarMeansAndBarrier) {
  run_ranks(3, test_options(), [](const DistributedContext& context) {
    EXPECT_DOUBLE_EQ(context.all_reduce_mean(static_cast<double>(context.rank())), 1.0);
    const auto means = context.all_reduce_mean(
        std::map<std::string, double>{{"a", context.rank() * 3.0}, {"b", 6.0}});
    EXPECT_DOUBLE_EQ(means.at("a"), 3.0);
    EXPECT_DOUBLE_EQ(means.at("b"), 6.0);
    EXPECT_EQ(context.is_main(), context.rank() == 0);
    EXPECT_TRUE(context.all_true(true));
    EXPECT_FALSE(context.all_true(context.rank() != 1));
    const auto start = std::chrono::steady_clock::now();
    if (context.rank() == 2) std::this_thread::sleep_for(std::chrono::milliseconds(300));
    context.barrier();
    EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(290));
  });
}

// A tiny regression net; `unused` never gets a gradient, `scale` is a buffer.
struct TinyNetImpl : torch::nn::Module {
  TinyNetImpl()
      : hidden(register_module("hidden", torch::nn::Linear(4, 8))),
        out(register_module("out", torch::nn::Linear(8, 1))),
        unused(register_module("unused", torch::nn::Linear(3, 3))),
        scale(register_buffer("scale", at::ones({1}))) {}
  at::Tensor forward(const at::Tensor& x) { return out(hidden(x).tanh()) * scale; }
  torch::nn::Linear hidden, out, unused;
  at::Tensor scale;
};
TORCH_MODULE(TinyNet);

constexpr int64_t kItems = 16;
constexpr int kSteps = 6;

struct Dataset {
  at::Tensor x, y;
};

Dataset fixed_dataset() {
  at::manual_seed(7);
  Dataset data;
  data.x = at::randn({kItems, 4}, at::kDouble);
  data.y = data.x.sum(1, true).sin();
  return data;
}

// Rank `rank` of `world` trains on its shard of the dataset, starting from rank 0's weights.
// Returns the parameters flattened and, through `losses`, the global loss per step.
at::Tensor train(const DistributedContext& context, std::vector<double>& losses) {
  const Dataset data = fixed_dataset();
  at::manual_seed(100 + context.rank());  // different initial weights per rank
  TinyNet net;
  net->to(at::kDouble);
  net->scale.fill_(1.0 + context.rank());
  context.broadcast_module(*net);

  const at::Tensor shard =
      at::tensor(shard_indices(kItems, context.rank(), context.world_size()), at::kLong);
  const at::Tensor x = data.x.index_select(0, shard), y = data.y.index_select(0, shard);
  // SGD sees the gradient scale (AdamW would not) and decays a zero-filled gradient's parameter.
  torch::optim::SGD optimizer(net->parameters(),
                              torch::optim::SGDOptions(0.1).momentum(0.9).weight_decay(0.1));
  for (int step = 0; step < kSteps; ++step) {
    optimizer.zero_grad();
    const at::Tensor loss = (net->forward(x) - y).pow(2).mean();
    loss.backward();
    context.all_reduce_gradients(net->parameters());
    optimizer.step();
    losses.push_back(context.all_reduce_mean(loss.item<double>()));
  }
  EXPECT_FALSE(net->unused->weight.grad().defined());
  std::vector<at::Tensor> flat;
  for (const at::Tensor& p : net->parameters()) flat.push_back(p.detach().reshape(-1));
  flat.push_back(net->scale);
  return at::cat(flat);
}

// Runs only inside the processes that DataParallelTest starts.
TEST(DistributedWorker, TrainOnShard) {
  const char* out = std::getenv("OMNIPOINT_DIST_TEST_OUT");
  if (out == nullptr) GTEST_SKIP() << "started by DataParallelTest only";
  DistributedOptions options = test_options();
  const DistributedContext context = DistributedContext::from_environment(options);
  ASSERT_EQ(context.world_size(), 2);
  std::vector<double> losses;
  const at::Tensor parameters = train(context, losses);
  const std::string prefix = std::string(out) + "/rank" + std::to_string(context.rank());
  io::write_npy(prefix + "_parameters.npy", parameters);
  io::write_npy(prefix + "_losses.npy", at::tensor(losses, at::kDouble));
  context.barrier();
}

TEST(DataParallelTest, TwoRanksMatchOneProcessOnTheCombinedBatch) {
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("omnipoint_dist_" + std::to_string(free_port()));
  std::filesystem::create_directories(out);
  ASSERT_EQ(setenv("OMNIPOINT_DIST_TEST_OUT", out.c_str(), 1), 0);
  const int code = launch_local(2, {"--gtest_filter=DistributedWorker.TrainOnShard"});
  unsetenv("OMNIPOINT_DIST_TEST_OUT");
  ASSERT_EQ(code, 0);

  std::vector<double> reference_losses;
  const at::Tensor reference = train(DistributedContext(), reference_losses);
  for (int rank = 0; rank < 2; ++rank) {
    const std::string prefix = (out / ("rank" + std::to_string(rank))).string();
    const at::Tensor parameters = io::read_npy(prefix + "_parameters.npy");
    const at::Tensor losses = io::read_npy(prefix + "_losses.npy");
    EXPECT_LE((parameters - reference).abs().max().item<double>(), 1e-6) << "rank " << rank;
    ASSERT_EQ(losses.numel(), kSteps);
    for (int step = 0; step < kSteps; ++step)
      EXPECT_NEAR(losses[step].item<double>(), reference_losses[static_cast<size_t>(step)], 1e-9)
          << step;
  }
  // The training moved the weights: equality is not the trivial one.
  at::manual_seed(100);
  TinyNet initial;
  initial->to(at::kDouble);
  EXPECT_GT((reference.narrow(0, 0, initial->hidden->weight.numel()) -
             initial->hidden->weight.reshape(-1))
                .abs()
                .max()
                .item<double>(),
            1e-3);
  std::filesystem::remove_all(out);
}

}  // namespace
}  // namespace omnipoint::train
