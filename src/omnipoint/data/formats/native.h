#pragma once
// What the readers of datasets' native layouts (this folder; the table in dataset_formats.cpp)
// share: listing a layout's files, split lists, decoding depth PNGs whose bit depth and size
// are checked first, and making the metric Sample. Every reader's own conventions (units,
// invalid codes, z-depth or distance, pixel centres) are written next to it, with their
// sources; the ones here hold for all of them:
//   - an item is named by its RGB file's path relative to the root ("/"-separated): the
//     sample id of `omnipoint eval`, the line of a split list, the manifest's key;
//   - a split list (public benchmarks' lists: "RGB [DEPTH [FOCAL]]" a line) names items by
//     their first field; further fields are not read (each reader derives its depth file from
//     the RGB file's name, as the native layout pairs them);
//   - the option "sequence" takes the dataset's own names (scenes, areas), several separated by
//     commas.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"

namespace omnipoint::data::formats {

// A PNG's header (its IHDR chunk): what a depth map must be is checked before decoding.
struct PngHeader {
  int64_t width = 0;
  int64_t height = 0;
  int bit_depth = 0;  // bits per sample: 1, 2, 4, 8 or 16
  int channels = 0;   // 1 grey, 2 grey + alpha, 3 RGB (and palette), 4 RGBA
};
// `bytes` is the file's beginning (at least 33 bytes); not a PNG -> std::runtime_error naming
// `path`.
PngHeader parse_png_header(const std::string& bytes, const std::string& path);
// The header of the PNG file `path` (missing, unreadable or not a PNG -> std::runtime_error
// naming it).
PngHeader read_png_header(const std::string& path);

// The stored values of a depth PNG that must have `bits` bits per sample and `channels`
// channels (1 or 3) and, when width > 0, the size width x height: float32 (H, W), or (H, W, 3).
// A missing file, another format, depth, channel count or size -> std::runtime_error naming
// the file and both, e.g. "PATH: expected a 16-bit grey PNG, got an 8-bit RGB one".
at::Tensor read_depth_png(const std::string& path, int bits, int channels, int64_t width = 0,
                          int64_t height = 0);
// A colour image (io::read_image: float32 (H, W, 3) in [0, 1]); with width > 0 it must be
// width x height (std::runtime_error naming the file otherwise).
at::Tensor read_rgb(const std::string& path, int64_t width = 0, int64_t height = 0);
// Throws std::runtime_error "PATH: W1xH1, but OTHER is W2xH2" unless map (H, W, ...) is
// width x height.
void expect_size(const at::Tensor& map, int64_t width, int64_t height, const std::string& path,
                 const std::string& other);

// The relative paths (sorted, "/"-separated) of the files under `root` matching `pattern`, a
// "/"-separated path whose components may hold '*' wildcards (any run of characters within one
// component), e.g. "area_*/pano/rgb/*_rgb.png". Hidden entries (".name") are skipped.
std::vector<std::string> find_files(const std::string& root, const std::string& pattern);
// Whether `name` matches the one-component wildcard pattern `pattern`.
bool wildcard_match(const std::string& pattern, const std::string& name);

// One line of a split list: its 1-based number and its whitespace-separated fields.
struct ListLine {
  int number = 0;
  std::vector<std::string> fields;
};
// A split list's lines (blank lines and '#' comments skipped; a CR before the newline
// dropped). A line of more than 3 fields, a path that is absolute or climbs out of the root
// ("..") or a NUL byte -> std::runtime_error naming `source`, the line and the problem.
std::vector<ListLine> parse_split_list(const std::string& text, const std::string& source);

// The values of option `name`, comma-separated ("" or absent: none).
std::vector<std::string> option_values(const DatasetLocation& location, const std::string& name);
// Option `name` as a number, `fallback` when not given; not a finite number in
// [minimum, maximum] -> std::invalid_argument naming the option.
double option_number(const DatasetLocation& location, const std::string& name, double fallback,
                     double minimum, double maximum);
// Option `name`, which must be one of `values` (the first is the default); another value ->
// std::invalid_argument naming the option and the values.
std::string option_choice(const DatasetLocation& location, const std::string& name,
                          const std::vector<std::string>& values);
// Whether `key` (an item's sequence, e.g. "Scene01/clone") is selected by the names given:
// none selects all, else a name that equals the key or its leading "/"-components.
bool selected(const std::string& key, const std::vector<std::string>& names);

// How a reader turns an item name into a Sample and the files it reads.
struct ItemReader {
  std::function<Sample(const std::string&)> read;
  std::function<std::vector<std::string>(const std::string&)> sources;
};

// The items of a dataset at `location`: with `location.split` one of the format's named splits,
// those of `found` (the items the root holds) in it; with another split, a split list file
// (each line's first field, mapped by `normalise` onto the reader's item name; an item with a
// missing source file is an error naming the list, its line and the file); else all of `found`.
// Then those whose `sequence_of(item)` is selected by option "sequence". No item ->
// std::runtime_error naming the root and `looked_for`.
struct ItemListing {
  std::vector<std::string> found;                              // from the root's files
  std::function<std::string(const std::string&)> normalise;    // a list's path -> item (or none)
  std::function<std::string(const std::string&)> sequence_of;  // item -> its sequence key
  std::string looked_for;                // what the layout's items are, for the "no item" error
  std::vector<std::string> split_names;  // the format's named splits (DatasetFormat::splits)
  std::function<bool(const std::string& split, const std::string& item)> in_split;
};
std::unique_ptr<Dataset> native_dataset(const DatasetLocation& location, ItemListing listing,
                                        ItemReader reader);
// The reader of items that are an image with one depth file beside it: `read(root, item)`
// makes the sample; its sources are root/item and root/depth_of(item).
ItemReader image_and_depth_reader(
    const std::string& root, const std::function<std::string(const std::string&)>& depth_of,
    const std::function<Sample(const std::string&, const std::string&)>& read);
// The entries (files and folders) of `folder` in name order; none when it cannot be read.
std::vector<std::filesystem::path> sorted_entries(const std::filesystem::path& folder);
// Throws std::runtime_error "dataset \"ROOT\": not a folder" unless the root is a folder.
void require_root(const DatasetLocation& location);

// Distance along `camera`'s unit rays from planar depth (camera-frame z): z / ray.z where z > 0
// and ray.z > 0, else 0. For perspective cameras (every ray forward).
at::Tensor distance_from_planar_depth(const at::Tensor& z, const camera::Camera& camera);
// The camera of a full 360 x 180 degree panorama of width x height: our EQUIRECTANGULAR, whose
// column 0 starts at longitude -pi and row 0 at the zenith. Every panorama dataset read here
// stores its rows top (zenith) to bottom and its columns as one turn about the vertical; where
// its own azimuth origin lies does not matter to a single-image sample (its camera frame is
// the dataset's turned about the vertical axis), and none is assumed.
camera::Camera full_panorama(int64_t width, int64_t height);

// A reader's sample: metric distances along `camera`'s unit rays, labelled where `labelled`
// (bool (H, W)) holds and the distance is finite and > 0 and the camera's ray is valid, 0
// elsewhere. Sizes that disagree or no labelled pixel -> std::runtime_error.
Sample metric_sample(const camera::Camera& camera, at::Tensor image, const at::Tensor& distance,
                     const at::Tensor& labelled);

// `path` joined to `root` (a relative "/"-separated path).
std::string join(const std::string& root, const std::string& path);
// The path with its last `suffix` replaced by `replacement` (the path unchanged when it does
// not end with `suffix`).
std::string replace_suffix(const std::string& path, const std::string& suffix,
                           const std::string& replacement);

}  // namespace omnipoint::data::formats
