#include "omnipoint/data/formats/native.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <new>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "omnipoint/data/png_text.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"

namespace omnipoint::data::formats {
namespace fs = std::filesystem;

namespace {

std::string size_text(int64_t width, int64_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

std::string png_kind(int bits, int channels) {
  static const char* const names[] = {"", "grey", "grey+alpha", "RGB", "RGBA"};
  const std::string article = bits == 8 ? "an " : "a ";
  return article + std::to_string(bits) + "-bit " + names[std::clamp(channels, 0, 4)];
}

// The first `count` bytes of a file (fewer when it is shorter).
std::string file_head(const std::string& path, std::size_t count) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error(path + ": cannot open the file (missing or unreadable)");
  std::string bytes(count, '\0');
  file.read(bytes.data(), static_cast<std::streamsize>(count));
  bytes.resize(static_cast<std::size_t>(file.gcount()));
  return bytes;
}

}  // namespace

PngHeader parse_png_header(const std::string& bytes, const std::string& path) {
  const data::PngHeader ihdr = data::read_png_header(bytes, path);
  PngHeader header;
  header.width = ihdr.width;
  header.height = ihdr.height;
  header.bit_depth = ihdr.bit_depth;
  // PNG colour types: 0 grey, 2 RGB, 3 palette, 4 grey + alpha, 6 RGBA.
  switch (ihdr.colour_type) {
    case 0:
      header.channels = 1;
      break;
    case 2:
    case 3:
      header.channels = 3;
      break;
    case 4:
      header.channels = 2;
      break;
    case 6:
      header.channels = 4;
      break;
    default:
      throw std::runtime_error(path + ": not a PNG file (unknown colour type)");
  }
  return header;
}

PngHeader read_png_header(const std::string& path) {
  return parse_png_header(file_head(path, 33), path);
}

at::Tensor read_depth_png(const std::string& path, int bits, int channels, int64_t width,
                          int64_t height) {
  const PngHeader header = read_png_header(path);
  if (header.bit_depth != bits || header.channels != channels)
    throw std::runtime_error(path + ": expected " + png_kind(bits, channels) + " PNG, got " +
                             png_kind(header.bit_depth, header.channels) + " one");
  if (width > 0 && (header.width != width || header.height != height))
    throw std::runtime_error(path + ": " + size_text(header.width, header.height) +
                             ", but the image is " + size_text(width, height));
  return io::read_image_values(path);
}

ItemReader image_and_depth_reader(
    const std::string& root, const std::function<std::string(const std::string&)>& depth_of,
    const std::function<Sample(const std::string&, const std::string&)>& read) {
  ItemReader reader;
  reader.read = [root, read](const std::string& item) { return read(root, item); };
  reader.sources = [root, depth_of](const std::string& item) {
    return std::vector<std::string>{join(root, item), join(root, depth_of(item))};
  };
  return reader;
}

std::vector<std::filesystem::path> sorted_entries(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> entries;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error))
    entries.push_back(entry.path());
  std::sort(entries.begin(), entries.end());
  return entries;
}

at::Tensor read_rgb(const std::string& path, int64_t width, int64_t height) {
  at::Tensor image = io::read_image(path);
  if (width > 0) expect_size(image, width, height, path, "the camera");
  return image;
}

void expect_size(const at::Tensor& map, int64_t width, int64_t height, const std::string& path,
                 const std::string& other) {
  if (map.size(0) != height || map.size(1) != width)
    throw std::runtime_error(path + ": " + size_text(map.size(1), map.size(0)) + ", but " + other +
                             " is " + size_text(width, height));
}

bool wildcard_match(const std::string& pattern, const std::string& name) {
  // Greedy matching with backtracking to the last '*' (one component: no '/').
  std::size_t p = 0, n = 0, star = std::string::npos, resume = 0;
  while (n < name.size()) {
    if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      resume = n;
    } else if (p < pattern.size() && pattern[p] == name[n]) {
      ++p, ++n;
    } else if (star != std::string::npos) {
      p = star + 1;
      n = ++resume;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

std::vector<std::string> find_files(const std::string& root, const std::string& pattern) {
  std::vector<std::string> components;
  std::stringstream parts(pattern);
  for (std::string part; std::getline(parts, part, '/');) components.push_back(part);
  std::vector<std::string> found;
  // Depth-first over the components; a component without '*' is looked up directly.
  std::function<void(const fs::path&, const std::string&, std::size_t)> walk =
      [&](const fs::path& folder, const std::string& relative, std::size_t depth) {
        const bool last = depth + 1 == components.size();
        const std::string& component = components[depth];
        std::error_code error;
        const auto visit = [&](const fs::path& path, const std::string& name) {
          const std::string child = relative.empty() ? name : relative + "/" + name;
          if (last ? fs::is_regular_file(path, error) : fs::is_directory(path, error))
            last ? found.push_back(child) : walk(path, child, depth + 1);
        };
        if (component.find('*') == std::string::npos) {
          visit(folder / component, component);
          return;
        }
        fs::directory_iterator entries(folder, error);
        if (error) return;
        for (const fs::directory_entry& entry : entries) {
          const std::string name = entry.path().filename().string();
          if (!name.empty() && name[0] != '.' && wildcard_match(component, name))
            visit(entry.path(), name);
        }
      };
  if (!components.empty()) walk(fs::path(root), "", 0);
  std::sort(found.begin(), found.end());
  return found;
}

std::vector<ListLine> parse_split_list(const std::string& text, const std::string& source) {
  std::vector<ListLine> lines;
  std::istringstream stream(text);
  int number = 0;
  for (std::string line; std::getline(stream, line);) {
    ++number;
    const auto fail = [&](const std::string& why) {
      throw std::runtime_error(source + ":" + std::to_string(number) + ": " + why);
    };
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find('\0') != std::string::npos) fail("holds a NUL byte");
    std::istringstream words(line);
    ListLine entry{number, {}};
    for (std::string word; words >> word;) entry.fields.push_back(word);
    if (entry.fields.empty() || entry.fields.front()[0] == '#') continue;
    if (entry.fields.size() > 3)
      fail("expected 1 to 3 fields (RGB [DEPTH [FOCAL]]), got " +
           std::to_string(entry.fields.size()));
    for (std::size_t i = 0; i < entry.fields.size() && i < 2; ++i) {
      const fs::path path(entry.fields[i]);
      if (path.is_absolute()) fail("\"" + entry.fields[i] + "\" is not relative to the root");
      for (const fs::path& part : path)
        if (part == "..") fail("\"" + entry.fields[i] + "\" climbs out of the root");
    }
    lines.push_back(std::move(entry));
  }
  return lines;
}

std::vector<std::string> option_values(const DatasetLocation& location, const std::string& name) {
  std::vector<std::string> values;
  std::stringstream text(option_or(location, name, ""));
  for (std::string value; std::getline(text, value, ',');)
    if (!value.empty()) values.push_back(value);
  return values;
}

double option_number(const DatasetLocation& location, const std::string& name, double fallback,
                     double minimum, double maximum) {
  const std::string text = option_or(location, name, "");
  if (text.empty()) return fallback;
  std::size_t used = 0;
  double value = NAN;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(value) || value < minimum || value > maximum) {
    std::ostringstream range;
    range << "a number in [" << minimum << ", " << maximum << "]";
    throw std::invalid_argument("option " + name + "=" + text + ": expected " + range.str());
  }
  return value;
}

std::string option_choice(const DatasetLocation& location, const std::string& name,
                          const std::vector<std::string>& values) {
  std::string value = option_or(location, name, values.front());
  if (std::find(values.begin(), values.end(), value) != values.end()) return value;
  std::string known;
  for (const std::string& v : values) known += (known.empty() ? "" : ", ") + v;
  throw std::invalid_argument("option " + name + "=" + value + ": expected one of " + known);
}

bool selected(const std::string& key, const std::vector<std::string>& names) {
  if (names.empty()) return true;
  for (const std::string& name : names)
    if (key == name || (key.size() > name.size() && key.compare(0, name.size(), name) == 0 &&
                        key[name.size()] == '/'))
      return true;
  return false;
}

void require_root(const DatasetLocation& location) {
  std::error_code error;
  if (!fs::is_directory(location.path, error))
    throw std::runtime_error("dataset \"" + location.path + "\": not a folder");
}

namespace {

// The items a split list names, each with all its source files present.
std::vector<std::string> listed_items(const DatasetLocation& location, const ItemListing& listing,
                                      const ItemReader& reader) {
  const std::string& list = location.split;
  std::error_code error;
  if (!fs::is_regular_file(list, error)) {
    std::string names;
    for (const std::string& name : listing.split_names) names += (names.empty() ? "" : ", ") + name;
    throw std::runtime_error("split \"" + list + "\": no split list file of that name" +
                             (names.empty() ? std::string() : " nor a split (" + names + ")"));
  }
  std::vector<std::string> items, missing;
  std::string first_missing;
  for (const ListLine& line : parse_split_list(io::read_file(list), list)) {
    const std::string item =
        listing.normalise ? listing.normalise(line.fields.front()) : line.fields.front();
    for (const std::string& source : reader.sources(item)) {
      if (fs::exists(source, error)) continue;
      if (missing.empty())
        first_missing = list + ":" + std::to_string(line.number) + ": names " + source;
      missing.push_back(source);
    }
    items.push_back(item);
  }
  if (!missing.empty())
    throw std::runtime_error(first_missing + ", which does not exist" +
                             (missing.size() > 1
                                  ? " (and " + std::to_string(missing.size() - 1) +
                                        " more missing files under \"" + location.path + "\")"
                                  : std::string()));
  return items;
}

}  // namespace

std::unique_ptr<Dataset> native_dataset(const DatasetLocation& location, ItemListing listing,
                                        ItemReader reader) {
  const auto& names = listing.split_names;
  std::vector<std::string> items;
  if (location.split.empty()) {
    items = std::move(listing.found);
  } else if (std::find(names.begin(), names.end(), location.split) != names.end()) {
    for (std::string& item : listing.found)
      if (listing.in_split(location.split, item)) items.push_back(std::move(item));
  } else {
    items = listed_items(location, listing, reader);
  }
  const std::vector<std::string> sequences = option_values(location, "sequence");
  if (!sequences.empty())
    items.erase(std::remove_if(items.begin(), items.end(),
                               [&](const std::string& item) {
                                 return !selected(listing.sequence_of(item), sequences);
                               }),
                items.end());
  if (items.empty())
    throw std::runtime_error("dataset \"" + location.path + "\": holds no items (" +
                             listing.looked_for +
                             (sequences.empty() ? std::string() : ", in the sequences given") +
                             (location.split.empty() ? ")" : ", in " + location.split + ")"));
  // The item named in front of whatever went wrong, then the sample's invariants checked.
  auto read = [read = std::move(reader.read)](const std::string& item) {
    std::optional<Sample> sample;
    try {
      sample.emplace(read(item));
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& error) {
      throw SampleError(item + ": " + error.what());
    }
    validate_sample(*sample, item);
    return std::move(*sample);
  };
  return std::make_unique<ListDataset>(std::move(items), std::move(read),
                                       std::move(reader.sources));
}

at::Tensor distance_from_planar_depth(const at::Tensor& z, const camera::Camera& camera) {
  const at::Tensor ray_z = camera.ray_map(at::kFloat).rays.select(-1, 2);
  const at::Tensor usable = (z > 0) & (ray_z > 0);
  return at::where(usable, z / at::where(usable, ray_z, at::ones_like(ray_z)), at::zeros_like(z));
}

camera::Camera full_panorama(int64_t width, int64_t height) {
  return camera::make_camera("EQUIRECTANGULAR", width, height, {});
}

Sample metric_sample(const camera::Camera& camera, at::Tensor image, const at::Tensor& distance,
                     const at::Tensor& labelled) {
  const int64_t width = camera.width(), height = camera.height();
  if (image.size(0) != height || image.size(1) != width || distance.size(0) != height ||
      distance.size(1) != width)
    throw std::runtime_error("the image (" + size_text(image.size(1), image.size(0)) +
                             ") and the depth (" + size_text(distance.size(1), distance.size(0)) +
                             ") must both be the camera's " + size_text(width, height));
  const at::Tensor values = distance.to(at::kFloat);
  const at::Tensor mask =
      labelled & at::isfinite(values) & (values > 0) & camera.ray_map(at::kFloat).valid;
  if (!mask.any().item<bool>()) throw std::runtime_error("no labelled pixel");
  Sample sample{camera, std::move(image), at::where(mask, values, at::zeros_like(values)), mask,
                true};
  return sample;
}

std::string join(const std::string& root, const std::string& path) {
  return (fs::path(root) / path).string();
}

std::string replace_suffix(const std::string& path, const std::string& suffix,
                           const std::string& replacement) {
  if (path.size() < suffix.size() ||
      path.compare(path.size() - suffix.size(), suffix.size(), suffix))
    return path;
  return path.substr(0, path.size() - suffix.size()) + replacement;
}

}  // namespace omnipoint::data::formats
