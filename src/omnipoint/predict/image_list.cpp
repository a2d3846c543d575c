#include "omnipoint/predict/image_list.h"

#include <algorithm>
#include <map>
#include <stdexcept>

#include "omnipoint/io/image.h"

namespace omnipoint::predict {

namespace fs = std::filesystem;

ImageList list_images(const std::vector<std::string>& inputs) {
  ImageList list;
  for (const std::string& input : inputs) {
    if (fs::is_directory(input)) {
      std::vector<fs::path> found;
      for (const auto& entry : fs::recursive_directory_iterator(
               input, fs::directory_options::follow_directory_symlink)) {
        if (!entry.is_regular_file()) continue;
        if (io::has_image_extension(entry.path().string()))
          found.push_back(entry.path());
        else if (entry.path().filename().string().front() != '.')
          ++list.skipped_files;
      }
      if (found.empty())
        throw std::invalid_argument("input folder " + input +
                                    ": no images in it or below it (PNG, JPEG, WebP, TIFF, BMP, "
                                    "JPEG 2000, PNM)");
      std::sort(found.begin(), found.end());
      for (const fs::path& path : found) {
        const fs::path relative = path.lexically_relative(input);
        list.images.push_back({path, relative, fs::path(relative).replace_extension()});
      }
    } else if (fs::exists(input)) {
      const fs::path path(input);
      list.images.push_back({path, path.filename(), path.stem()});
    } else {
      throw std::invalid_argument("input " + input + ": no such file or folder");
    }
  }
  std::map<std::string, int> seen;
  for (ImageEntry& image : list.images)
    if (const int earlier = seen[image.output.generic_string()]++; earlier > 0)
      image.output += "_" + std::to_string(earlier + 1);
  return list;
}

std::optional<fs::path> per_image_file(const fs::path& folder, const ImageEntry& image,
                                       const std::vector<std::string>& extensions) {
  for (const fs::path& stem :
       {folder / fs::path(image.relative).replace_extension(), folder / image.path.stem()})
    for (const std::string& extension : extensions)
      if (fs::path candidate = fs::path(stem) += extension; fs::is_regular_file(candidate))
        return candidate;
  return std::nullopt;
}

}  // namespace omnipoint::predict
