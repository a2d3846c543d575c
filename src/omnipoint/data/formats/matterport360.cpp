// "matterport360": Matterport3D panoramas stitched by UniFuse's MATLAB scripts (the "Matterport3D
// 360" of UniFuse, BiFuse and DA²), from the 18 undistorted views of each tripod position.
//
// Layout (UniFuse/Matterport3D/stitch.m, alibaba/UniFuse-Unidirectional-Fusion @5da3a4e; the
// lists UniFuse/datasets/matterport3d_{train,val,test}.txt):
//   ROOT/<scene>/pano_skybox_color/<panorama>.jpg   colour stitched from the skybox faces (the
//                                                    lists use it)
//   ROOT/<scene>/pano_color/<panorama>.jpg          colour stitched from the 18 views
//   ROOT/<scene>/pano_depth/<panorama>.png           2048x1024
// Conventions (stitch.m):
//   - depth: 16-bit grey PNG of uint16(distance * 4000): metres = value / 4000 (Matterport3D's
//     0.25 mm unit, kept by the stitcher); 0 = no reading;
//   - distance along the ray, not z: the stitcher multiplies each view's z-depth by
//     sqrt(X^2 + Y^2 + 1) before combining the views;
//   - a full equirectangular panorama, zenith on top (native.h: full_panorama).
// Split lists: "<scene>/pano_skybox_color/<id>.jpg <scene>/pano_depth/<id>.png" (UniFuse's,
// DA²'s matterport3d.txt = UniFuse's test list). Option "sequence": scenes.
#include <ATen/ATen.h>

#include <filesystem>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

constexpr double kMetresPerUnit = 1.0 / 4000.0;

std::string scene_of(const std::string& item) {
  return item.substr(0, item.find('/'));
}

std::string depth_of(const std::string& item) {
  return scene_of(item) + "/pano_depth/" + fs::path(item).stem().string() + ".png";
}

Sample read_panorama(const std::string& root, const std::string& item) {
  const at::Tensor image = formats::read_rgb(join(root, item));
  const at::Tensor code =
      formats::read_depth_png(join(root, depth_of(item)), 16, 1, image.size(1), image.size(0));
  return formats::metric_sample(formats::full_panorama(image.size(1), image.size(0)), image,
                                code * kMetresPerUnit, code > 0);
}

std::unique_ptr<Dataset> open_matterport360(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  const std::string color =
      formats::option_choice(location, "color", {"skybox", "stitched"}) == "skybox"
          ? "pano_skybox_color"
          : "pano_color";
  formats::ItemListing listing;
  listing.found = formats::find_files(root, "*/" + color + "/*.jpg");
  listing.sequence_of = scene_of;
  listing.looked_for = "*/" + color + "/*.jpg";
  return formats::native_dataset(location, std::move(listing),
                                 formats::image_and_depth_reader(root, depth_of, read_panorama));
}

}  // namespace

DatasetFormat matterport360_format() {
  return {
      "matterport360",
      "Matterport3D panoramas stitched by UniFuse: <scene>/pano_skybox_color/*.jpg, "
      "<scene>/pano_depth/*.png (16-bit, 1/4000 m, 0 missing, distance)",
      {{"sequence", "scenes, comma-separated"},
       {"color", "skybox | stitched: pano_skybox_color/ (default, as the lists) or pano_color/"}},
      {},
      open_matterport360};
}

}  // namespace omnipoint::data
