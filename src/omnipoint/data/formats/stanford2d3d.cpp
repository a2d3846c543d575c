// "stanford2d3d": the panoramas of Stanford 2D-3D-Semantics (2D3DS), as downloaded
// (`noXYZ` or `withXYZ`: only pano/rgb and pano/depth are read).
//
// Layout (2D-3D-Semantics README, alexsax/2D-3D-Semantics @54a5329; the file names with single
// underscores as the public split lists of DA² and UniFuse write them, not the README's
// "camera_{uuid}__{room}"):
//   ROOT/area_{1,2,3,4,5a,5b,6}/pano/rgb/camera_<uuid>_<room>_<i>_frame_equirectangular_domain_rgb.png
//   ROOT/area_X/pano/depth/camera_<uuid>_<room>_<i>_frame_equirectangular_domain_depth.png
// Conventions (the same README):
//   - depth: 16-bit grey PNG, metres = value / 512 ("a sensitivity of 1/512 m", 128 m at
//     most); 65535 = missing (0 is no distance either);
//   - in the panoramas the depth is the distance from the camera's centre (the perspective
//     crops of data/ hold z-depth): distance along the unit ray, as ours;
//   - the panorama is a full equirectangular image, zenith on top (native.h: full_panorama).
// Split lists: DA²'s eval/datasets/splits/2d3ds.txt ("area_X/pano/rgb/NAME area_X/pano/depth/
// NAME") and UniFuse's stanford2d3d_{train,val,test}.txt ("area_X/rgb_/NAME area_X/depth/NAME",
// its own preprocessed folders): a line names the panorama by its area (first component) and
// RGB file name, read from pano/rgb and pano/depth here. Option "sequence": areas (area_5a).
#include <ATen/ATen.h>

#include <filesystem>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

constexpr double kMetresPerUnit = 1.0 / 512.0;
constexpr double kMissing = 65535.0;

std::string area_of(const std::string& item) {
  return item.substr(0, item.find('/'));
}

// area_X/pano/rgb/NAME from any path whose first component is the area.
std::string item_of(const std::string& listed) {
  return area_of(listed) + "/pano/rgb/" + fs::path(listed).filename().string();
}

std::string depth_of(const std::string& item) {
  return area_of(item) + "/pano/depth/" +
         formats::replace_suffix(fs::path(item).filename().string(), "_rgb.png", "_depth.png");
}

Sample read_panorama(const std::string& root, const std::string& item) {
  const std::string depth_path = join(root, depth_of(item));
  const at::Tensor image = formats::read_rgb(join(root, item));
  const at::Tensor code = formats::read_depth_png(depth_path, 16, 1, image.size(1), image.size(0));
  return formats::metric_sample(formats::full_panorama(image.size(1), image.size(0)), image,
                                code * kMetresPerUnit, code != kMissing);
}

std::unique_ptr<Dataset> open_stanford2d3d(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  formats::ItemListing listing;
  listing.found = formats::find_files(root, "area_*/pano/rgb/*_rgb.png");
  listing.normalise = item_of;
  listing.sequence_of = area_of;
  listing.looked_for = "area_*/pano/rgb/*_rgb.png";
  return formats::native_dataset(location, std::move(listing),
                                 formats::image_and_depth_reader(root, depth_of, read_panorama));
}

}  // namespace

DatasetFormat stanford2d3d_format() {
  return {"stanford2d3d",
          "Stanford 2D-3D-Semantics panoramas: area_*/pano/{rgb,depth}/ (16-bit depth, 1/512 m, "
          "65535 missing, distance)",
          {{"sequence", "areas, comma-separated (area_5a,area_5b: fold 1's test)"}},
          {},
          open_stanford2d3d};
}

}  // namespace omnipoint::data
