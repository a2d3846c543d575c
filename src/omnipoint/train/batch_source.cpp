#include "omnipoint/train/batch_source.h"

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/synth_dataset.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/infer/teacher.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::train {
namespace {

constexpr uint64_t kTokenStream = 0x746f6b656e73ULL;   // separates the per-step token draw
constexpr uint64_t kBucketStream = 0x6275636b6574ULL;  // and the per-step bucket draw

std::unique_ptr<data::Dataset> open_source(const DatasetSource& source) {
  if (!source.format.empty()) {
    data::DatasetLocation location{source.root};
    location.split = source.split;
    location.options = source.options;
    return data::open_dataset(source.format, location);
  }
  if (!source.synth) return data::open_dataset("folders", {source.folders});
  std::vector<camera::Camera> cameras;  // parsed at load (train_config.h), here at the bucket size
  for (camera::Camera camera : source.synth_source.cameras) {
    if (camera.width() != source.width || camera.height() != source.height)
      camera = camera.resized(source.width, source.height);
    cameras.push_back(std::move(camera));
  }
  return std::make_unique<data::synth::SynthDataset>(source.synth_source.scenes,
                                                     std::move(cameras));
}

std::string source_name(const DatasetSource& source) {
  if (!source.format.empty()) return source.format + " " + source.root;
  return source.synth ? "synth" : source.folders;
}

// `text` with each `name` in it replaced by "<sample>".
std::string without_name(std::string text, const std::string& name) {
  const std::string placeholder = "<sample>";
  for (auto at = text.find(name); !name.empty() && at != std::string::npos;
       at = text.find(name, at + placeholder.size()))
    text.replace(at, name.size(), placeholder);
  return text;
}

}  // namespace

uint64_t derived_seed(uint64_t seed, uint64_t stream, uint64_t index) {
  return data::synth::mix64(data::synth::mix64(seed + data::synth::mix64(stream)) + index);
}

bool BatchSource::Request::operator==(const Request& other) const {
  return step == other.step && conditions == other.conditions && rank == other.rank &&
         world_size == other.world_size && stream == other.stream && bucket == other.bucket;
}

struct BatchSource::BadSamples {
  std::mutex mutex;
  std::map<std::pair<size_t, data::ItemIndex>, std::string> reasons;  // (source, item) -> reason
  std::vector<int64_t> per_source;                                    // bad items of each source
  std::map<std::string, int64_t> skipped;                             // draws by reason
  std::vector<std::string> warnings;                                  // not taken yet
};

// One background thread making the prefetched batch; a batch not taken when another is asked
// for is stopped and dropped.
class BatchSource::Prefetcher {
 public:
  using Make = std::function<TrainingBatch(const Request&, const std::atomic<bool>& stop)>;
  explicit Prefetcher(Make make) : make_(std::move(make)) {}
  ~Prefetcher() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
      if (job_) job_->stop = true;
    }
    changed_.notify_all();
    if (worker_.joinable()) worker_.join();
  }
  Prefetcher(const Prefetcher&) = delete;
  Prefetcher& operator=(const Prefetcher&) = delete;

  void start(const Request& request) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (job_ && job_->request == request) return;
      if (job_) job_->stop = true;
      job_ = std::make_shared<Job>();
      job_->request = request;
      if (!worker_.joinable()) worker_ = std::thread([this] { work(); });
    }
    changed_.notify_all();
  }

  // The batch of `request` when it is the one prefetched (waiting for it; its error is
  // rethrown here); nothing otherwise.
  std::optional<TrainingBatch> take(const Request& request) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!job_ || !(job_->request == request)) return std::nullopt;
    const std::shared_ptr<Job> job = job_;
    changed_.wait(lock, [&] { return job->finished; });
    if (job_ == job) job_.reset();
    if (job->stop) return std::nullopt;  // replaced meanwhile by another thread's prefetch
    if (job->error) std::rethrow_exception(job->error);
    return std::move(job->batch);
  }

 private:
  struct Job {
    Request request;
    std::atomic<bool> stop{false};
    bool started = false, finished = false;  // under mutex_
    TrainingBatch batch;
    std::exception_ptr error;
  };

  void work() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      changed_.wait(lock, [&] { return stopping_ || (job_ && !job_->started); });
      if (stopping_) return;
      const std::shared_ptr<Job> job = job_;
      job->started = true;
      lock.unlock();
      TrainingBatch batch;
      std::exception_ptr error;
      try {
        batch = make_(job->request, job->stop);
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      job->batch = std::move(batch);
      job->error = error;
      job->finished = true;
      changed_.notify_all();
    }
  }

  Make make_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::shared_ptr<Job> job_;  // the latest prefetch, until taken
  bool stopping_ = false;
  std::thread worker_;
};

BatchSource::BatchSource(const TrainConfig& config)
    : config_(config), bad_samples_(std::make_unique<BadSamples>()) {
  for (size_t i = 0; i < config_.datasets.size(); ++i) {
    const DatasetSource& source = config_.datasets[i];
    const auto same_size = [&](const Bucket& b) {
      return b.width == source.width && b.height == source.height;
    };
    auto bucket = std::find_if(buckets_.begin(), buckets_.end(), same_size);
    if (bucket == buckets_.end())
      bucket = buckets_.insert(buckets_.end(), Bucket{source.width, source.height, {}});
    bucket->sources.push_back(i);
    datasets_.push_back(open_source(source));
  }
  bad_samples_->per_source.assign(datasets_.size(), 0);
  if (config_.a2p) {
    const int64_t tokens =
        config_.a2p_teacher_tokens > 0 ? config_.a2p_teacher_tokens : config_.num_tokens[1];
    try {
      const augment::Teacher network =
          infer::teacher(infer::load_network(config_.a2p_teacher), tokens);
      // One network call at a time: a prefetch and an evaluation batch may both need it.
      auto mutex = std::make_shared<std::mutex>();
      teacher_ = [network, mutex](const at::Tensor& image, const camera::Camera& camera) {
        const std::lock_guard<std::mutex> lock(*mutex);
        return network(image, camera);
      };
    } catch (const std::exception& error) {
      throw std::runtime_error("A2P teacher \"" + config_.a2p_teacher + "\": " + error.what());
    }
  }
  prefetcher_ =
      std::make_unique<Prefetcher>([this](const Request& request, const std::atomic<bool>& stop) {
        return make_batch(request, stop);
      });
}

BatchSource::~BatchSource() = default;

double BatchSource::source_weight(size_t source, bool conditions) const {
  const DatasetSource& dataset = config_.datasets[source];
  return dataset.labelled || (conditions && config_.a2p) ? dataset.weight : 0.0;
}

double BatchSource::bucket_weight(const Bucket& bucket, bool conditions) const {
  double weight = 0;
  for (const size_t source : bucket.sources) weight += source_weight(source, conditions);
  return weight;
}

std::map<std::string, int64_t> BatchSource::skipped_samples() const {
  const std::lock_guard<std::mutex> lock(bad_samples_->mutex);
  return bad_samples_->skipped;
}

std::vector<std::string> BatchSource::take_warnings() {
  const std::lock_guard<std::mutex> lock(bad_samples_->mutex);
  return std::exchange(bad_samples_->warnings, {});
}

const BatchSource::Bucket& BatchSource::step_bucket(const Request& request) const {
  // The step's bucket: drawn by weight (one draw per step, the same on every rank), or given.
  const Bucket* bucket = nullptr;
  if (request.bucket >= 0) {
    for (size_t i = 0; i < buckets_.size() && !bucket; ++i) {
      const Bucket& candidate =
          buckets_[(static_cast<size_t>(request.bucket) + i) % buckets_.size()];
      if (bucket_weight(candidate, request.conditions) > 0) bucket = &candidate;
    }
  } else if (buckets_.size() == 1) {
    bucket = &buckets_.front();
  } else {
    double total = 0;
    for (const Bucket& b : buckets_) total += bucket_weight(b, request.conditions);
    data::synth::Random draw(derived_seed(config_.seed, request.stream ^ kBucketStream,
                                          static_cast<uint64_t>(request.step)),
                             0);
    double pick = draw.uniform() * total;
    for (const Bucket& b : buckets_) {
      const double weight = bucket_weight(b, request.conditions);
      if (weight <= 0) continue;
      bucket = &b;
      if (pick < weight) break;
      pick -= weight;
    }
  }
  if (!bucket) throw std::logic_error("training data: no source can be used in this stage");
  return *bucket;
}

data::Sample BatchSource::draw_sample(size_t source, data::synth::Random& random) const {
  const data::Dataset& dataset = *datasets_[source];
  BadSamples& bad = *bad_samples_;
  const auto give_up_when_none_left = [&] {  // under bad.mutex
    if (bad.per_source[source] == dataset.size())
      throw std::runtime_error("training data \"" + source_name(config_.datasets[source]) +
                               "\": no usable sample (all " + std::to_string(dataset.size()) +
                               " are bad; see the warnings)");
  };
  for (;;) {
    // A bad sample met before is skipped unread: the draws are the same either way, so what
    // an item gets does not depend on what other items or threads met first.
    const data::ItemIndex index = dataset.draw(random);
    {
      const std::lock_guard<std::mutex> lock(bad.mutex);
      const auto known = bad.reasons.find({source, index});
      if (known != bad.reasons.end()) {
        ++bad.skipped[known->second];
        give_up_when_none_left();
        continue;
      }
    }
    try {
      return dataset.item(index);
    } catch (const data::SampleError& error) {
      const std::lock_guard<std::mutex> lock(bad.mutex);
      const std::string reason = without_name(error.what(), dataset.item_name(index));
      if (bad.reasons.emplace(std::pair{source, index}, reason).second) {
        ++bad.per_source[source];
        bad.warnings.push_back(std::string("bad sample skipped, another drawn in its place: ") +
                               error.what());
      }
      ++bad.skipped[reason];
      give_up_when_none_left();
    }
  }
}

TrainingBatch BatchSource::make_batch(const Request& request, const std::atomic<bool>& stop) const {
  const Bucket& bucket = step_bucket(request);
  const double total_weight = bucket_weight(bucket, request.conditions);
  const int64_t batch_size = config_.batch_size;
  const auto make_item = [&](int64_t k) {
    const uint64_t index =
        static_cast<uint64_t>((request.step * request.world_size + request.rank) * batch_size + k);
    data::synth::Random random(derived_seed(config_.seed, request.stream, index), 0);
    // The data source, by weight, among the bucket's usable ones.
    double pick = random.uniform() * total_weight;
    size_t source = 0;
    for (const size_t candidate : bucket.sources) {
      const double weight = source_weight(candidate, request.conditions);
      if (weight <= 0) continue;
      source = candidate;  // the last usable one, should rounding leave pick >= the total
      if (pick < weight) break;
      pick -= weight;
    }
    const data::Sample drawn = draw_sample(source, random);
    // An unlabelled sample (the "images" format's) may only come from a "labels": false source.
    if (!drawn.labelled && config_.datasets[source].labelled)
      throw std::runtime_error("training data \"" + source_name(config_.datasets[source]) +
                               "\": its samples have no labels; declare it \"labels\": false "
                               "(it then enters through A2P)");
    const data::Sample sample = data::fit_sample(drawn, bucket.width, bucket.height);
    const ItemContext context{&config_, request.conditions, config_.datasets[source].labelled,
                              &teacher_};
    return make_training_item(sample, context, random);
  };
  // Each item is a pure function of its index, so threads take whole items (their ops then
  // run single-threaded inside) and the batch does not depend on the thread count. A2P's
  // teacher runs a network per item: those batches stay on the calling thread.
  std::vector<TrainingItem> items(static_cast<size_t>(batch_size));
  const auto make_items = [&](int64_t begin, int64_t end) {
    for (int64_t k = begin; k < end && !stop; ++k) items[static_cast<size_t>(k)] = make_item(k);
  };
  if (config_.a2p)
    make_items(0, batch_size);
  else
    util::parallel_for(0, batch_size, 1, make_items);
  if (stop) return {};
  data::synth::Random tokens(derived_seed(config_.seed, request.stream ^ kTokenStream,
                                          static_cast<uint64_t>(request.step)),
                             0);
  return collate(items, tokens.integer(static_cast<int>(config_.num_tokens[0]),
                                       static_cast<int>(config_.num_tokens[1])));
}

TrainingBatch BatchSource::batch(int64_t step, bool conditions, int64_t rank, int64_t world_size,
                                 uint64_t stream, int64_t bucket) const {
  const Request request{step, conditions, rank, world_size, stream, bucket};
  if (std::optional<TrainingBatch> prefetched = prefetcher_->take(request))
    return std::move(*prefetched);
  static const std::atomic<bool> kGoOn{false};
  return make_batch(request, kGoOn);
}

void BatchSource::prefetch(int64_t step, bool conditions, int64_t rank, int64_t world_size,
                           uint64_t stream, int64_t bucket) const {
  prefetcher_->start({step, conditions, rank, world_size, stream, bucket});
}

}  // namespace omnipoint::train
