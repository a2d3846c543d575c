#include "omnipoint/data/dataset.h"

#include <algorithm>
#include <map>
#include <mutex>
#include <new>
#include <optional>
#include <tuple>
#include <utility>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/synth/random.h"

namespace omnipoint::data {
namespace {

// The registered formats, the built-in ones from the start (a reader registered by a static
// object in a static library's unreferenced file would never run).
struct Registry {
  std::mutex mutex;
  std::map<std::string, DatasetFormat> formats;
  Registry() {
    for (DatasetFormat& format : builtin_dataset_formats()) {
      const std::string name = format.name;
      formats.emplace(name, std::move(format));
    }
  }
};
Registry& registry() {
  static Registry instance;
  return instance;
}

}  // namespace

ListDataset::ListDataset(std::vector<std::string> items,
                         std::function<Sample(const std::string&)> read, Sources sources)
    : items_(std::move(items)), read_(std::move(read)), sources_(std::move(sources)) {}

int64_t ListDataset::size() const {
  return static_cast<int64_t>(items_.size());
}

Sample ListDataset::item(const ItemIndex& index) const {
  const std::string& name = items_.at(static_cast<size_t>(index.index));
  try {
    return read_(name);
  } catch (const std::bad_alloc&) {
    throw;  // no property of the item
  } catch (const SampleError&) {
    throw;
  } catch (const std::exception& error) {
    throw SampleError(error.what());
  }
}

std::string ListDataset::item_name(const ItemIndex& index) const {
  return items_.at(static_cast<size_t>(index.index));
}

std::vector<std::string> ListDataset::item_sources(const ItemIndex& index) const {
  if (!sources_) return Dataset::item_sources(index);
  return sources_(items_.at(static_cast<size_t>(index.index)));
}

bool operator<(const ItemIndex& a, const ItemIndex& b) {
  return std::tie(a.index, a.seed) < std::tie(b.index, b.seed);
}

Dataset::~Dataset() = default;

std::vector<std::string> Dataset::item_sources(const ItemIndex& index) const {
  return {item_name(index)};
}

ItemIndex Dataset::draw(synth::Random& random) const {
  return {random.integer(0, static_cast<int>(size()) - 1), 0};
}

void register_dataset_format(DatasetFormat format) {
  if (format.name.empty() || !format.open)
    throw std::invalid_argument("register_dataset_format: needs a name and a reader");
  Registry& formats = registry();
  const std::lock_guard<std::mutex> lock(formats.mutex);
  const std::string name = format.name;
  if (!formats.formats.emplace(name, std::move(format)).second)
    throw std::invalid_argument("dataset format \"" + name + "\" is registered already");
}

void register_dataset_format(const std::string& name, DatasetReader reader) {
  DatasetFormat format;
  format.name = name;
  format.open = std::move(reader);
  register_dataset_format(std::move(format));
}

std::vector<DatasetFormat> dataset_format_list() {
  Registry& formats = registry();
  const std::lock_guard<std::mutex> lock(formats.mutex);
  std::vector<DatasetFormat> list;
  for (const auto& entry : formats.formats) list.push_back(entry.second);
  return list;
}

std::vector<std::string> dataset_formats() {
  std::vector<std::string> names;
  for (const DatasetFormat& format : dataset_format_list()) names.push_back(format.name);
  return names;
}

std::unique_ptr<Dataset> open_dataset(const std::string& format, const DatasetLocation& location) {
  std::optional<DatasetFormat> found;
  {
    Registry& formats = registry();
    const std::lock_guard<std::mutex> lock(formats.mutex);
    const auto entry = formats.formats.find(format);
    if (entry != formats.formats.end()) found = entry->second;
  }
  const auto listed = [](const auto& names) {
    std::string text;
    for (const auto& name : names) text += (text.empty() ? "" : ", ") + name;
    return text.empty() ? std::string("none") : text;
  };
  if (!found)
    throw std::invalid_argument("dataset format \"" + format +
                                "\": unknown (known: " + listed(dataset_formats()) + ")");
  for (const auto& [name, value] : location.options)
    if (found->options.count(name) == 0) {
      std::vector<std::string> known;
      for (const auto& option : found->options) known.push_back(option.first);
      throw std::invalid_argument("dataset format \"" + format + "\": no option \"" + name +
                                  "\" (its options: " + listed(known) + ")");
    }
  return found->open(location);
}

std::string option_or(const DatasetLocation& location, const std::string& name,
                      const std::string& fallback) {
  const auto found = location.options.find(name);
  return found == location.options.end() ? fallback : found->second;
}

}  // namespace omnipoint::data
