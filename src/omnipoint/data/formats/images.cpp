// "images": a folder of unlabelled images with one camera for all: Diverse360 or 360+x
// panorama frames, a fleet's fisheye frames. The source of the paper's A2P self-training (a
// training source with "labels": false, whose items A2P pseudo-labels); evaluation refuses it.
//
// Layout: ROOT/**/<name>.<ext>, every image file OpenCV decodes (io::has_image_extension: PNG,
// JPEG, WebP, TIFF, ...) at any depth below the root, in path order; hidden entries (".name")
// skipped. An item is the image's path relative to the root.
// Conventions:
//   - the camera: option "camera", required, in any form `predict --camera` takes
//     (io/camera_file.h: a spec string, a cameras.txt with an optional #ID, a camera JSON);
//     a form without a size (UniK3D's JSON) takes each image's. An image of another size than
//     the camera is an error naming both;
//   - the Sample is unlabelled (sample.h: labelled = false, distance 0, mask false, not
//     metric); the pixels are taken as stored (no EXIF rotation).
// Option sequence: sub-folders (their paths below the root).
#include <ATen/ATen.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/image.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

// The image files below `folder` (relative to `root`, "/"-separated), hidden entries skipped.
void collect(const fs::path& folder, const fs::path& root, std::vector<std::string>& found) {
  for (const fs::path& entry : formats::sorted_entries(folder)) {
    const std::string name = entry.filename().string();
    if (name.empty() || name[0] == '.') continue;
    std::error_code error;
    if (fs::is_directory(entry, error))
      collect(entry, root, found);
    else if (fs::is_regular_file(entry, error) && io::has_image_extension(name))
      found.push_back(fs::relative(entry, root, error).generic_string());
  }
}

// The camera of `spec` for the image at `path`, which must have its size.
camera::Camera image_camera(const std::string& spec, const at::Tensor& image,
                            const std::string& path) {
  camera::Camera camera = [&] {
    try {
      return io::read_camera(spec, camera::ImageSize{image.size(1), image.size(0)});
    } catch (const std::exception& error) {
      throw std::runtime_error("option camera=" + spec + ": " + error.what());
    }
  }();
  formats::expect_size(image, camera.width(), camera.height(), path,
                       "the camera (" + camera.to_spec() + ")");
  return camera;
}

Sample read_image_item(const std::string& root, const std::string& item, const std::string& spec) {
  const std::string path = join(root, item);
  at::Tensor image = formats::read_rgb(path);
  const camera::Camera camera = image_camera(spec, image, path);
  const int64_t height = camera.height(), width = camera.width();
  Sample sample{camera, std::move(image), at::zeros({height, width}, at::kFloat),
                at::zeros({height, width}, at::kBool), false};
  sample.labelled = false;
  return sample;
}

std::unique_ptr<Dataset> open_images(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  const std::string spec = option_or(location, "camera", "");
  if (spec.empty())
    throw std::invalid_argument(
        "images: option camera is required (the one camera of all the images: a spec or a "
        "camera file, as predict --camera takes)");
  formats::ItemListing listing;
  collect(root, root, listing.found);
  listing.sequence_of = [](const std::string& item) {
    return fs::path(item).parent_path().generic_string();
  };
  listing.looked_for = "image files (.png, .jpg, ...) at any depth";
  formats::ItemReader reader;
  reader.read = [root, spec](const std::string& item) { return read_image_item(root, item, spec); };
  reader.sources = [root](const std::string& item) {
    return std::vector<std::string>{join(root, item)};
  };
  auto dataset = formats::native_dataset(location, std::move(listing), std::move(reader));
  // A bad camera fails here, at the first image's size, rather than at every item (an
  // unreadable first image is that item's error, reported when it is read).
  const std::string first_path = join(root, dataset->item_name({0, 0}));
  at::Tensor first;
  try {
    first = formats::read_rgb(first_path);
  } catch (const std::runtime_error&) {
  }
  if (first.defined()) image_camera(spec, first, first_path);
  return dataset;
}

}  // namespace

DatasetFormat images_format() {
  return {"images",
          "unlabelled images (.png, .jpg, ...; any depth below the root) with one camera for all: "
          "A2P self-training's source (\"labels\": false); evaluation refuses it",
          {{"camera",
            "required: the camera of every image, any predict --camera form (spec string, "
            "cameras.txt[#ID], camera JSON)"},
           {"sequence", "sub-folders below the root, comma-separated"}},
          {},
          open_images};
}

}  // namespace omnipoint::data
