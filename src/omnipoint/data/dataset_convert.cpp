#include "omnipoint/data/dataset_convert.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "omnipoint/data/sample.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::data {
namespace fs = std::filesystem;

namespace {

constexpr size_t kMaxFolderName = 200;  // below every file system's 255-byte name limit
const char* const kManifest = "manifest.jsonl";

// The format option that --camera / --sequence set.
struct NamedOption {
  const char* flag;
  const char* option;
  const std::string* value;
};

}  // namespace

void DatasetConvertOptions::Check() const {
  const auto fail = [](const std::string& why) {
    throw std::invalid_argument("data convert: " + why);
  };
  if (format.empty()) fail("the format is not given");
  if (location.path.empty()) fail("the root is not given");
  if (output_path.empty()) fail("the output folder is not given");
  if (every < 1) fail("every must be >= 1");
  if (limit < 0) fail("limit must be >= 0 (0: every item)");
  if (resume && overwrite) fail("resume and overwrite exclude each other");
  for (const NamedOption& named : {NamedOption{"--camera", "camera", &camera},
                                   NamedOption{"--sequence", "sequence", &sequence}})
    if (!named.value->empty() && location.options.count(named.option) != 0)
      fail(std::string(named.flag) + " and the format option \"" + named.option +
           "\" are both given");
}

std::string sample_folder_name(const std::string& item, const std::string& root) {
  fs::path path = fs::path(item).lexically_normal();
  if (!root.empty()) {
    const fs::path relative = path.lexically_relative(fs::path(root).lexically_normal());
    if (!relative.empty() && *relative.begin() != "..") path = relative;
  }
  path.replace_extension();
  std::string name;
  for (const fs::path& part : path) {
    const std::string text = part.string();
    if (text.empty() || text == "/" || text == ".") continue;
    if (!name.empty()) name += '-';
    for (const char c : text)
      name +=
          std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' ? c : '_';
  }
  if (name.empty()) name = "item";
  if (name.size() > kMaxFolderName) name = name.substr(name.size() - kMaxFolderName);
  if (name.front() == '.') name.front() = '_';  // hidden: a staging folder's look
  return name;
}

DatasetConvert::DatasetConvert(DatasetConvertOptions options, DatasetConvertObserver* observer)
    : options_(std::move(options)), observer_(observer) {
  options_.Check();
}

namespace {

// The location with --camera / --sequence as the format's options; a format that declares no
// such option is named.
DatasetLocation located(const DatasetConvertOptions& options) {
  DatasetLocation location = options.location;
  std::optional<DatasetFormat> format;
  for (DatasetFormat& known : dataset_format_list())
    if (known.name == options.format) format = std::move(known);
  for (const NamedOption& named : {NamedOption{"--camera", "camera", &options.camera},
                                   NamedOption{"--sequence", "sequence", &options.sequence}}) {
    if (named.value->empty()) continue;
    if (format && format->options.count(named.option) == 0)
      throw std::invalid_argument("data convert: " + std::string(named.flag) +
                                  ": dataset format \"" + options.format + "\" has no option \"" +
                                  named.option + "\" (see `omnipoint data formats`)");
    location.options[named.option] = *named.value;
  }
  return location;
}

// Whether `folder` holds anything but stale staging folders of an interrupted run.
bool holds_anything(const fs::path& folder) {
  std::error_code error;
  for (fs::directory_iterator entry(folder, error), end; !error && entry != end;
       entry.increment(error))
    if (!io::is_staging_folder(entry->path())) return true;
  return false;
}

// The chosen items with their folder names; names that two items share get the item's index.
std::vector<ConvertedItem> choose_items(const Dataset& dataset,
                                        const DatasetConvertOptions& options) {
  std::vector<ConvertedItem> items;
  for (int64_t i = 0; i < dataset.size(); i += options.every) {
    if (options.limit > 0 && static_cast<int64_t>(items.size()) >= options.limit) break;
    ConvertedItem item;
    item.index = i;
    item.name = dataset.item_name({i, 0});
    item.folder = sample_folder_name(item.name, options.location.path);
    item.sources = dataset.item_sources({i, 0});
    items.push_back(std::move(item));
  }
  std::map<std::string, int> uses;
  for (const ConvertedItem& item : items) ++uses[item.folder];
  for (ConvertedItem& item : items)
    if (uses[item.folder] > 1) item.folder += "-" + std::to_string(item.index);
  return items;
}

std::string manifest_line(const ConvertedItem& item) {
  return nlohmann::json{{"sample", item.folder}, {"item", item.name}, {"sources", item.sources}}
             .dump() +
         "\n";
}

}  // namespace

DatasetConvertReport DatasetConvert::Run() const {
  const std::string what = "data convert: ";
  const std::unique_ptr<Dataset> dataset = open_dataset(options_.format, located(options_));
  const fs::path out(options_.output_path);
  std::error_code error;
  const bool existed = fs::exists(out, error);
  if (existed && !fs::is_directory(out, error))
    throw std::runtime_error(what + out.string() + ": exists and is not a folder");
  if (existed && !options_.resume && !options_.overwrite && holds_anything(out))
    throw std::runtime_error(what + out.string() +
                             " holds files already (--resume keeps the items converted there, "
                             "--overwrite writes them anew)");
  fs::create_directories(out, error);
  if (error)
    throw std::runtime_error(what + "cannot create the output folder " + out.string() + ": " +
                             error.message());

  const std::vector<ConvertedItem> items = choose_items(*dataset, options_);
  DatasetConvertReport report;
  report.items = static_cast<int64_t>(items.size());
  if (observer_) observer_->on_start(report.items);
  std::string manifest;
  for (size_t k = 0; k < items.size(); ++k) {
    const ConvertedItem& item = items[k];
    const auto ordinal = static_cast<int64_t>(k);
    if (observer_) observer_->on_item(ordinal, item);
    const fs::path folder = out / item.folder;
    if (options_.resume && fs::is_directory(folder, error)) {
      ++report.kept;
      manifest += manifest_line(item);
      if (observer_) observer_->on_item_done(ordinal);
      continue;
    }
    // An item's own faults (unreadable, invalid) skip it; the output's stop the run.
    std::optional<Sample> sample;
    try {
      sample.emplace(dataset->item({item.index, 0}));
      validate_sample(*sample, item.name);
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& failure) {
      std::string why = failure.what();
      if (why.find(item.name) == std::string::npos) why = item.name + ": " + why;
      report.skipped.push_back(why);
      if (observer_) {
        observer_->on_skipped(item, why);
        observer_->on_item_done(ordinal);
      }
      continue;
    }
    io::StagedFolder staged(folder);
    const nlohmann::json source = {{"source", {{"format", options_.format}, {"item", item.name}}}};
    write_sample(staged.path().string(), *sample, source.dump());
    staged.commit();
    ++report.converted;
    manifest += manifest_line(item);
    if (observer_) observer_->on_item_done(ordinal);
  }
  if (report.converted + report.kept == 0) {
    if (!existed) fs::remove(out, error);  // empty: made by this run
    throw std::runtime_error(what + "nothing converted: " + std::to_string(report.skipped.size()) +
                             " of " + std::to_string(report.items) + " items skipped (first: " +
                             (report.skipped.empty() ? "none" : report.skipped.front()) + ")");
  }
  report.manifest_path = (out / kManifest).string();
  io::write_file_atomically(report.manifest_path,
                            [&](std::ostream& stream) { stream << manifest; });
  return report;
}

}  // namespace omnipoint::data
