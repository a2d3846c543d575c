#include "omnipoint/data/dataset_index.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "omnipoint/data/moge_format.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::data {
namespace fs = std::filesystem;

namespace {

bool is_folder_sample(const fs::path& folder) {
  return fs::exists(folder / "meta.json") &&
         (fs::exists(folder / "distance.npy") || fs::exists(folder / "depth.npy"));
}

bool is_moge_instance(const fs::path& folder) {
  return fs::exists(folder / "meta.json") && fs::exists(folder / "depth.png");
}

std::string relative_id(const fs::path& folder, const fs::path& root) {
  const std::string id = fs::relative(folder, root).generic_string();
  return id.empty() || id == "." ? folder.filename().string() : id;
}

void collect(const fs::path& folder, const fs::path& root, int depth,
             std::vector<DatasetItem>& out) {
  if (is_folder_sample(folder)) {
    out.push_back({folder.string(), relative_id(folder, root), SampleFormat::kFolder});
    return;
  }
  if (is_moge_instance(folder)) {
    out.push_back({folder.string(), relative_id(folder, root), SampleFormat::kMoge});
    return;
  }
  if (fs::exists(folder / ".index.txt")) {
    for (const auto& instance : list_moge_instances(folder.string()))
      out.push_back({instance, relative_id(instance, root), SampleFormat::kMoge});
    return;
  }
  if (depth >= kMaxDatasetDepth) return;
  std::vector<fs::path> children;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.is_directory() && !io::is_staging_folder(entry.path()))  // not written yet
      children.push_back(entry.path());
  std::sort(children.begin(), children.end());
  for (const auto& child : children) collect(child, root, depth + 1, out);
}

}  // namespace

std::vector<DatasetItem> list_dataset(const std::string& root) {
  const fs::path base(root);
  if (!fs::is_directory(base)) throw std::runtime_error("dataset " + root + ": not a folder");
  std::vector<DatasetItem> items;
  collect(base, base, 0, items);
  if (items.empty())
    throw std::runtime_error("dataset " + root +
                             ": no samples found (expected sample folders with meta.json and "
                             "distance.npy or depth.npy, or a MoGe benchmark with meta.json and "
                             "depth.png per instance)");
  return items;
}

Sample read_dataset_item(const DatasetItem& item, bool moge_metric) {
  return item.format == SampleFormat::kMoge ? read_moge_instance(item.path, moge_metric)
                                            : read_sample(item.path);
}

}  // namespace omnipoint::data
