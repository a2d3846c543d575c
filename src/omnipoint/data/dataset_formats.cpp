#include "omnipoint/data/dataset_formats.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>
#include <utility>

#include "omnipoint/data/moge_format.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;

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
  return std::make_unique<ListDataset>(std::move(folders), read_sample);
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
  return std::make_unique<ListDataset>(std::move(instances), [metric](const std::string& folder) {
    return read_moge_instance(folder, metric);
  });
}

}  // namespace

DatasetFormat sample_folders_format() {
  return {"folders",
          "a directory of sample folders (image.png, distance.npy or depth.npy, mask, meta.json "
          "with the camera; docs/DATASET.md)",
          {},
          {},
          open_sample_folders};
}

DatasetFormat moge_format() {
  return {"moge",
          "a MoGe evaluation benchmark root (.index.txt, instance folders with image.jpg, "
          "depth.png, meta.json)",
          {},
          {},
          open_moge_benchmark};
}

std::vector<DatasetFormat> builtin_dataset_formats() {
  return {sample_folders_format(), moge_format(),         kitti_raw_format(),     kitti360_format(),
          rig_log_format(),        stanford2d3d_format(), matterport360_format(), pano3d_format(),
          panosuncg_format(),      structured3d_format(), hypersim_format(),      vkitti2_format(),
          arkitscenes_format(),    tartanair_format(),    images_format()};
}

}  // namespace omnipoint::data
