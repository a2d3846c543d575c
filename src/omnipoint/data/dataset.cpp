#include "omnipoint/data/dataset.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <new>
#include <tuple>
#include <utility>

#include "omnipoint/data/moge_format.h"
#include "omnipoint/data/synth/random.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;

// A reader's error as the SampleError a caller may skip the item for (memory exhaustion is no
// property of the item and stays what it is).
template <typename Read>
Sample read_or_sample_error(const Read& read) {
  try {
    return read();
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const SampleError&) {
    throw;
  } catch (const std::exception& error) {
    throw SampleError(error.what());
  }
}

// Items named by folder paths, read by `read_folder`.
class FolderListDataset : public Dataset {
 public:
  FolderListDataset(std::vector<std::string> folders,
                    std::function<Sample(const std::string&)> read_folder)
      : folders_(std::move(folders)), read_folder_(std::move(read_folder)) {}

  int64_t size() const override { return static_cast<int64_t>(folders_.size()); }
  Sample item(const ItemIndex& index) const override {
    const std::string& folder = folders_.at(static_cast<size_t>(index.index));
    return read_or_sample_error([&] { return read_folder_(folder); });
  }
  std::string item_name(const ItemIndex& index) const override {
    return folders_.at(static_cast<size_t>(index.index));
  }

 private:
  std::vector<std::string> folders_;
  std::function<Sample(const std::string&)> read_folder_;
};

std::unique_ptr<Dataset> open_sample_folders(const DatasetLocation& location) {
  const std::string& root = location.path;
  std::error_code error;
  if (!fs::is_directory(root, error))
    throw std::runtime_error("dataset \"" + root + "\": not a directory of sample folders");
  std::vector<std::string> folders;
  // (A staging folder is a sample still being written by `omnipoint synth`.)
  for (const fs::directory_entry& entry : fs::directory_iterator(root))
    if (entry.is_directory() && !io::is_staging_folder(entry.path()))
      folders.push_back(entry.path().string());
  if (folders.empty())
    throw std::runtime_error("dataset \"" + root + "\": holds no sample folders");
  std::sort(folders.begin(), folders.end());
  return std::make_unique<FolderListDataset>(std::move(folders), read_sample);
}

std::unique_ptr<Dataset> open_moge_benchmark(const DatasetLocation& location) {
  std::vector<std::string> instances;
  try {
    instances = list_moge_instances(location.path);
  } catch (const std::exception& error) {
    throw std::runtime_error("dataset \"" + location.path + "\": " + error.what());
  }
  if (instances.empty())
    throw std::runtime_error("dataset \"" + location.path + "\": holds no MoGe instances");
  const bool metric = location.metric;
  return std::make_unique<FolderListDataset>(
      std::move(instances),
      [metric](const std::string& folder) { return read_moge_instance(folder, metric); });
}

// The registered formats, the built-in ones from the start (a reader registered by a static
// object in a static library's unreferenced file would never run).
struct Registry {
  std::mutex mutex;
  std::map<std::string, DatasetReader> readers{{"folders", open_sample_folders},
                                               {"moge", open_moge_benchmark}};
};
Registry& registry() {
  static Registry instance;
  return instance;
}

}  // namespace

bool operator<(const ItemIndex& a, const ItemIndex& b) {
  return std::tie(a.index, a.seed) < std::tie(b.index, b.seed);
}

Dataset::~Dataset() = default;

ItemIndex Dataset::draw(synth::Random& random) const {
  return {random.integer(0, static_cast<int>(size()) - 1), 0};
}

void register_dataset_format(const std::string& name, DatasetReader reader) {
  if (name.empty() || !reader)
    throw std::invalid_argument("register_dataset_format: needs a name and a reader");
  Registry& formats = registry();
  const std::lock_guard<std::mutex> lock(formats.mutex);
  if (!formats.readers.emplace(name, std::move(reader)).second)
    throw std::invalid_argument("dataset format \"" + name + "\" is registered already");
}

std::vector<std::string> dataset_formats() {
  Registry& formats = registry();
  const std::lock_guard<std::mutex> lock(formats.mutex);
  std::vector<std::string> names;
  for (const auto& entry : formats.readers) names.push_back(entry.first);
  return names;
}

std::unique_ptr<Dataset> open_dataset(const std::string& format, const DatasetLocation& location) {
  DatasetReader reader;
  {
    Registry& formats = registry();
    const std::lock_guard<std::mutex> lock(formats.mutex);
    const auto found = formats.readers.find(format);
    if (found != formats.readers.end()) reader = found->second;
  }
  if (!reader) {
    std::string known;
    for (const std::string& name : dataset_formats()) known += (known.empty() ? "" : ", ") + name;
    throw std::invalid_argument("dataset format \"" + format + "\": unknown (known: " + known +
                                ")");
  }
  return reader(location);
}

}  // namespace omnipoint::data
