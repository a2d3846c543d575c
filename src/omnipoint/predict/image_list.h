#pragma once
// The images of a predict job (predict_job.h, `omnipoint predict IMAGES...`): files are taken
// as given; folders are searched recursively for every image format OpenCV decodes
// (io::has_image_extension), sorted, and each image's output folder mirrors its path below the
// input folder (OUT/a/b/photo/ for FOLDER/a/b/photo.jpg), as MoGe's scripts do.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace omnipoint::predict {

struct ImageEntry {
  std::filesystem::path path;      // the image file
  std::filesystem::path relative;  // below its input folder (the file name for a file input)
  std::filesystem::path output;    // the output folder below OUT: relative without extension
};

struct ImageList {
  std::vector<ImageEntry> images;
  int64_t skipped_files = 0;  // files in the folders that are not images (reported, not fatal)
};

// Errors (std::invalid_argument): a missing input, a folder with no image. Output folders stay
// unique: a second "photo" (photo.jpg beside photo.png) becomes "photo_2".
ImageList list_images(const std::vector<std::string>& inputs);

// The file of `image` in a folder of per-image files (sparse depth): the one with the image's
// path below its input folder, else with its file name, and one of `extensions` (in order of
// preference). nullopt when there is none.
std::optional<std::filesystem::path> per_image_file(const std::filesystem::path& folder,
                                                    const ImageEntry& image,
                                                    const std::vector<std::string>& extensions);

}  // namespace omnipoint::predict
