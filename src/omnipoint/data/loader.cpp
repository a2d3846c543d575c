#include "omnipoint/data/loader.h"
#include "omnipoint/io/camera_file.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>

#include "omnipoint/data/moge_format.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/data/transform.h"

namespace omnipoint::data {
namespace fs = std::filesystem;

namespace {

struct IndexedSource {
  DataSource source;
  std::vector<std::string> items;        // sample folders (folder, moge)
  std::vector<camera::Camera> cameras;   // synth
  std::vector<synth::SceneKind> scenes;  // synth
};

IndexedSource index_source(const DataSource& s) {
  IndexedSource out{s, {}, {}, {}};
  if (!(s.weight > 0) || !std::isfinite(s.weight))
    throw std::invalid_argument("data source '" + s.path + "': weight must be positive");
  if (s.kind == "synth") {
    if (s.cameras.empty())
      throw std::invalid_argument("synth data source: needs at least one camera spec");
    for (const auto& spec : s.cameras) out.cameras.push_back(io::read_camera(spec));
    for (const auto& name : s.scenes) out.scenes.push_back(synth::parse_scene_kind(name));
    if (out.scenes.empty())
      throw std::invalid_argument("synth data source: needs at least one scene kind");
    return out;
  }
  if (s.kind == "folder") {
    const fs::path root(s.path);
    if (fs::exists(root / "meta.json")) {
      out.items.push_back(root.string());
    } else if (fs::is_directory(root)) {
      for (const auto& e : fs::directory_iterator(root))
        if (e.is_directory() && fs::exists(e.path() / "meta.json"))
          out.items.push_back(e.path().string());
      std::sort(out.items.begin(), out.items.end());
    }
  } else if (s.kind == "moge") {
    out.items = list_moge_instances(s.path);
  } else {
    throw std::invalid_argument("data source kind '" + s.kind +
                                "': expected folder, moge or synth");
  }
  if (out.items.empty())
    throw std::runtime_error("data source " + s.path +
                             ": no samples (expected sample folders with meta.json)");
  return out;
}

// Resize to cover (width, height) keeping the aspect ratio, then a random window of it.
struct Fit {
  int64_t resized_w, resized_h, x0, y0;
};
Fit fit_to(int64_t w, int64_t h, int64_t width, int64_t height, synth::Random& rng) {
  const double scale = std::max(double(width) / w, double(height) / h);
  Fit f{};
  f.resized_w = std::max<int64_t>(width, static_cast<int64_t>(std::ceil(w * scale - 1e-9)));
  f.resized_h = std::max<int64_t>(height, static_cast<int64_t>(std::ceil(h * scale - 1e-9)));
  f.x0 = rng.integer(0, static_cast<int>(f.resized_w - width));
  f.y0 = rng.integer(0, static_cast<int>(f.resized_h - height));
  return f;
}

std::runtime_error no_usable_samples(const IndexedSource& src) {
  return std::runtime_error("data source " + src.source.path + ": no usable samples (all " +
                            std::to_string(src.items.size()) + " failed; see the log)");
}

std::string replace_all(std::string text, const std::string& what, const std::string& with) {
  for (auto at = text.find(what); !what.empty() && at != std::string::npos;
       at = text.find(what, at + with.size()))
    text.replace(at, what.size(), with);
  return text;
}

}  // namespace

std::pair<int64_t, int64_t> batch_image_size(int64_t num_tokens, int64_t patch_size,
                                             double aspect) {
  if (num_tokens < 1 || patch_size < 1 || !(aspect > 0))
    throw std::invalid_argument(
        "batch_image_size: num_tokens, patch_size and aspect must be positive");
  const auto cols = std::max<int64_t>(1, std::llround(std::sqrt(num_tokens * aspect)));
  const auto rows = std::max<int64_t>(1, std::llround(std::sqrt(num_tokens / aspect)));
  return {cols * patch_size, rows * patch_size};
}

struct Loader::State {
  LoaderOptions options;
  std::vector<IndexedSource> sources;
  double total_weight = 0;

  mutable std::mutex mutex;
  std::condition_variable ready, space;
  std::map<int64_t, Batch> done;
  std::map<int64_t, std::exception_ptr> failed;
  int64_t next_to_build = 0, next_to_deliver = 0;
  bool stopping = false;
  std::map<std::string, int64_t> skipped;
  std::map<size_t, std::set<std::string>> bad;  // per source
  std::vector<std::thread> workers;

  Sample draw(int64_t width, int64_t height, synth::Random& rng, std::string& from) {
    for (;;) {
      double pick = rng.uniform(0, total_weight);
      size_t s = 0;
      while (s + 1 < sources.size() && pick >= sources[s].source.weight)
        pick -= sources[s++].source.weight;
      const auto& src = sources[s];
      if (src.source.kind == "synth") {
        const auto seed = rng.next_u64() >> 33;
        const auto kind = src.scenes[rng.integer(0, static_cast<int>(src.scenes.size()) - 1)];
        const auto& cam = src.cameras[rng.integer(0, static_cast<int>(src.cameras.size()) - 1)];
        const auto f = fit_to(cam.width(), cam.height(), width, height, rng);
        const auto fitted =
            cam.resized(f.resized_w, f.resized_h).cropped(f.x0, f.y0, width, height);
        from = "synth:" + synth::scene_kind_name(kind) + ":" + std::to_string(seed);
        return synth::synthesize(kind, seed, fitted).sample;
      }
      const auto& item = src.items[rng.integer(0, static_cast<int>(src.items.size()) - 1)];
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (bad[s].size() == src.items.size()) throw no_usable_samples(src);
        if (bad[s].count(item)) {
          ++skipped["known bad sample"];
          continue;
        }
      }
      // Reading draws nothing from rng, so skipping a known-bad sample and failing to read
      // it consume the same draws: the stream does not depend on worker timing.
      std::optional<Sample> sample;
      try {
        sample = src.source.kind == "moge" ? read_moge_instance(item, src.source.metric)
                                           : read_sample(item);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex);
        std::cerr << "omnipoint: skipping sample " << item << ": " << e.what() << "\n";
        ++skipped[replace_all(e.what(), item, "<sample>")];
        bad[s].insert(item);
        if (bad[s].size() == src.items.size()) throw no_usable_samples(src);
        continue;
      }
      const auto f = fit_to(sample->camera.width(), sample->camera.height(), width, height, rng);
      if (f.resized_w != sample->camera.width() || f.resized_h != sample->camera.height())
        sample = resize_sample(*sample, f.resized_w, f.resized_h);
      sample = crop_sample(*sample, f.x0, f.y0, width, height);
      if (!sample->mask.any().item<bool>()) {
        std::lock_guard<std::mutex> lock(mutex);
        ++skipped["crop without labelled pixels"];
        continue;
      }
      from = item;
      return *sample;
    }
  }

  Batch build(int64_t k) {
    const auto& o = options;
    synth::Random batch_rng(o.seed, static_cast<std::uint64_t>(k) << 1);
    const double aspect =
        std::exp(batch_rng.uniform(std::log(o.min_aspect), std::log(o.max_aspect)));
    const auto [width, height] = batch_image_size(o.num_tokens, o.patch_size, aspect);
    std::vector<at::Tensor> images, rays, distances, masks;
    Batch batch;
    std::vector<bool> metric;
    for (int64_t j = 0; j < o.batch_size; ++j) {
      synth::Random rng(o.seed, (static_cast<std::uint64_t>(k * o.batch_size + j) << 1) | 1);
      std::string from;
      Sample s = draw(width, height, rng, from);
      auto image =
          o.augment ? photometric_augment(s.image, o.photometric, rng.next_u64()) : s.image;
      images.push_back(image.permute({2, 0, 1}));
      rays.push_back(s.camera.ray_map(at::kFloat).rays);
      distances.push_back(s.distance);
      masks.push_back(s.mask);
      metric.push_back(s.metric);
      batch.cameras.push_back(s.camera);
      batch.sources.push_back(from);
    }
    batch.image = at::stack(images);
    batch.rays = at::stack(rays);
    batch.distance = at::stack(distances);
    batch.mask = at::stack(masks);
    batch.metric = at::empty({o.batch_size}, at::kBool);
    for (int64_t j = 0; j < o.batch_size; ++j) batch.metric[j] = bool(metric[j]);
    return batch;
  }

  void work() {
    for (;;) {
      int64_t k;
      {
        std::unique_lock<std::mutex> lock(mutex);
        space.wait(lock,
                   [&] { return stopping || next_to_build < next_to_deliver + options.prefetch; });
        if (stopping) return;
        k = next_to_build++;
      }
      try {
        Batch b = build(k);
        std::lock_guard<std::mutex> lock(mutex);
        done.emplace(k, std::move(b));
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        failed.emplace(k, std::current_exception());
      }
      ready.notify_all();
    }
  }
};

Loader::Loader(LoaderOptions options) : state_(std::make_shared<State>()) {
  if (options.sources.empty()) throw std::invalid_argument("loader: no data sources");
  if (options.batch_size < 1 || options.workers < 1 || options.prefetch < 1)
    throw std::invalid_argument("loader: batch_size, workers and prefetch must be >= 1");
  if (!(options.min_aspect > 0) || options.max_aspect < options.min_aspect)
    throw std::invalid_argument("loader: expected 0 < min_aspect <= max_aspect");
  state_->options = std::move(options);
  for (const auto& s : state_->options.sources) {
    state_->sources.push_back(index_source(s));
    state_->total_weight += s.weight;
  }
  for (int i = 0; i < state_->options.workers; ++i)
    state_->workers.emplace_back([state = state_.get()] { state->work(); });
}

Loader::~Loader() {
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->stopping = true;
  }
  state_->space.notify_all();
  for (auto& t : state_->workers) t.join();
}

Batch Loader::next() {
  auto& s = *state_;
  std::unique_lock<std::mutex> lock(s.mutex);
  const int64_t k = s.next_to_deliver;
  s.ready.wait(lock, [&] { return s.done.count(k) || s.failed.count(k); });
  ++s.next_to_deliver;
  s.space.notify_all();
  if (auto f = s.failed.find(k); f != s.failed.end()) {
    const auto error = f->second;
    s.failed.erase(f);
    std::rethrow_exception(error);
  }
  Batch batch = std::move(s.done.at(k));
  s.done.erase(k);
  return batch;
}

std::map<std::string, int64_t> Loader::skipped() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->skipped;
}

}  // namespace omnipoint::data
