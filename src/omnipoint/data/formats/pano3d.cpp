// "pano3d": Pano3D's Matterport3D panoramas (the 'M3D' part of Pano3D; DAC trains and tests on
// it), rendered from the Matterport3D meshes.
//
// Layout (DAC's lists splits/matterport3d/*.txt, yuliangguo/depth_any_camera @267d61a, from
// Pano3D's M3D_v1_*.yaml; DAC's dac/dataloders/m3d.py):
//   ROOT/<scene>/<i>_spherical_1_emission_center_0.png   colour
//   ROOT/<scene>/<i>_spherical_1_depth_center_0.exr      depth
// (an RGB file "<stem>_emission_<rest>.png" pairs with "<stem>_depth_<rest>.exr").
// Conventions (Pano3D's page; DAC reads the EXR with IMREAD_ANYDEPTH and depth_scale 1):
//   - depth: single-channel 32-bit float OpenEXR in metres; inf = no geometry (invalid), and so
//     are NaN and values <= 0;
//   - distance along the ray of a full equirectangular panorama (native.h: full_panorama).
// OpenEXR decoding goes through OpenCV (io::read_image_values); OpenCV builds that disable it
// unless OPENCV_IO_ENABLE_OPENEXR is set say so in the error (Debian's 4.6 reads EXR as is).
// Split lists: "<scene>/<..._emission_center_0.png> <..._depth_center_0.exr> <focal>" (DAC's).
// Option "sequence": scenes.
#include <ATen/ATen.h>

#include <stdexcept>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/io/image.h"

namespace omnipoint::data {
namespace {

using formats::join;

std::string scene_of(const std::string& item) {
  return item.substr(0, item.find('/'));
}

std::string depth_of(const std::string& item) {
  const std::size_t at = item.rfind("_emission_");
  if (at == std::string::npos) return item;
  return formats::replace_suffix(item.substr(0, at) + "_depth_" + item.substr(at + 10), ".png",
                                 ".exr");
}

at::Tensor read_exr_depth(const std::string& path) {
  at::Tensor depth;
  try {
    depth = io::read_image_values(path);
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(std::string(error.what()) +
                             " (OpenEXR: this OpenCV may need OPENCV_IO_ENABLE_OPENEXR=1 in the "
                             "environment, or lacks OpenEXR)");
  }
  if (depth.dim() != 2)
    throw std::runtime_error(path + ": expected a single-channel float EXR, got " +
                             std::to_string(depth.size(2)) + " channels");
  return depth;
}

Sample read_panorama(const std::string& root, const std::string& item) {
  const at::Tensor image = formats::read_rgb(join(root, item));
  const std::string depth_path = join(root, depth_of(item));
  const at::Tensor depth = read_exr_depth(depth_path);
  formats::expect_size(depth, image.size(1), image.size(0), depth_path, "the image");
  return formats::metric_sample(formats::full_panorama(image.size(1), image.size(0)), image, depth,
                                at::isfinite(depth));
}

std::unique_ptr<Dataset> open_pano3d(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  formats::ItemListing listing;
  listing.found = formats::find_files(root, "*/*_emission_*.png");
  listing.sequence_of = scene_of;
  listing.looked_for = "<scene>/*_emission_*.png with *_depth_*.exr";
  return formats::native_dataset(location, std::move(listing),
                                 formats::image_and_depth_reader(root, depth_of, read_panorama));
}

}  // namespace

DatasetFormat pano3d_format() {
  return {"pano3d",
          "Pano3D Matterport3D panoramas: <scene>/*_emission_center_0.png with "
          "*_depth_center_0.exr (float metres, inf invalid, distance; needs OpenCV's OpenEXR)",
          {{"sequence", "scenes, comma-separated"}},
          {},
          open_pano3d};
}

}  // namespace omnipoint::data
