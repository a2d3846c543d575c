// "panosuncg": PanoSUNCG's rendered panoramas (the "rotated" release that UniFuse and DA² use).
//
// Layout (UniFuse/datasets/panosuncg_{train,val,test}.txt, alibaba/UniFuse-Unidirectional-Fusion
// @5da3a4e; DA²'s eval/datasets/splits/panosuncg.txt, EnVision-Research/DA-2 @d659838, relative
// to PanoSUNCG/rotated): "<k>.txt" is a folder name
//   ROOT/rotated/<scene md5>/<k>.txt/<i>_color.png
//   ROOT/rotated/<scene md5>/<k>.txt/<i>_depth.png
// ROOT may also be the rotated/ folder itself; a list line may start with "rotated/" or not.
// Conventions:
//   - depth: an 8-bit PNG (3 equal channels, or grey), metres = mean over channels of
//     value * depth_scale with depth_scale = 10/255 (UniFuse's panosuncg.py: value * 10 / 255,
//     then the channel mean; valid 0 < d <= 10 m); 0 = no geometry. DA² reads channel 0 / 20,
//     but it median-aligns, so its constant says nothing about metres: option depth_scale;
//   - the distance along the ray of a full equirectangular panorama [unverified: neither loader
//     says distance or z; a panorama's depth is read as distance by both] (native.h);
//   - the resolution is the files' [unverified: UniFuse trains at 256x512].
// Option "sequence": scene md5s.
#include <ATen/ATen.h>

#include <filesystem>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

constexpr const char* kPrefix = "rotated/";

// Items are relative to the folder holding the scenes (ROOT/rotated or ROOT).
std::string item_of(const std::string& listed) {
  return listed.rfind(kPrefix, 0) == 0 ? listed.substr(8) : listed;
}

std::string scene_of(const std::string& item) {
  return item.substr(0, item.find('/'));
}

std::string depth_of(const std::string& item) {
  return formats::replace_suffix(item, "_color.png", "_depth.png");
}

Sample read_panorama(const std::string& scenes, const std::string& item, double scale) {
  const at::Tensor image = formats::read_rgb(join(scenes, item));
  const std::string depth_path = join(scenes, depth_of(item));
  const int channels = formats::read_png_header(depth_path).channels == 1 ? 1 : 3;
  at::Tensor code = formats::read_depth_png(depth_path, 8, channels, image.size(1), image.size(0));
  if (code.dim() == 3) code = code.mean(-1);
  return formats::metric_sample(formats::full_panorama(image.size(1), image.size(0)), image,
                                code * scale, code > 0);
}

std::unique_ptr<Dataset> open_panosuncg(const DatasetLocation& location) {
  formats::require_root(location);
  std::error_code error;
  const std::string scenes = fs::is_directory(fs::path(location.path) / "rotated", error)
                                 ? join(location.path, "rotated")
                                 : location.path;
  const double scale = formats::option_number(location, "depth_scale", 10.0 / 255.0, 1e-6, 1e3);
  DatasetLocation in_scenes = location;
  in_scenes.path = scenes;
  formats::ItemListing listing;
  listing.found = formats::find_files(scenes, "*/*.txt/*_color.png");
  listing.normalise = item_of;
  listing.sequence_of = scene_of;
  listing.looked_for = "rotated/<scene>/<k>.txt/*_color.png";
  const auto read = [scale](const std::string& root, const std::string& item) {
    return read_panorama(root, item, scale);
  };
  return formats::native_dataset(in_scenes, std::move(listing),
                                 formats::image_and_depth_reader(scenes, depth_of, read));
}

}  // namespace

DatasetFormat panosuncg_format() {
  return {"panosuncg",
          "PanoSUNCG panoramas: rotated/<scene>/<k>.txt/<i>_{color,depth}.png (8-bit depth, "
          "10/255 m, 0 missing)",
          {{"sequence", "scene md5s, comma-separated"},
           {"depth_scale",
            "metres per depth unit, default 10/255 (UniFuse's; DA²'s 1/20 is not metric)"}},
          {},
          open_panosuncg};
}

}  // namespace omnipoint::data
