// "vkitti2": Virtual KITTI 2 (Naver Labs Europe), the clones of five KITTI sequences rendered
// under varied conditions, from a stereo pair of pinhole cameras.
//
// Layout (the dataset's vkitti_2.0.3_{rgb,depth,textgt} archives extracted into one root; the
// folder names as third-party loaders read them, research notes §8):
//   ROOT/SceneXX/<variation>/frames/rgb/Camera_K/rgb_NNNNN.jpg
//   ROOT/SceneXX/<variation>/frames/depth/Camera_K/depth_NNNNN.png
//   ROOT/SceneXX/<variation>/intrinsic.txt
// with XX in 01, 02, 06, 18, 20, <variation> one of clone, fog, morning, overcast, rain, sunset,
// 15-deg-left, 15-deg-right, 30-deg-left, 30-deg-right, and K = 0 (left) or 1 (right).
// Conventions and their sources:
//   - depth: 16-bit grey PNG in centimetres, the planar depth z (a z-buffer, as KITTI's), turned
//     into distance along each pixel's ray here; 65535 (655.35 m, the encoding's ceiling) is
//     the sky: no label (the VKITTI 2 README; third-party read_vkitti_png_depth);
//   - intrinsic.txt (native_text.h): per frame and camera "fx fy cx cy" in pixels. The dataset's
//     own values, cx = 620.5 and cy = 187 for its 1242 x 375 images, put the principal point at
//     (W - 1) / 2, (H - 1) / 2: the centre of the image when pixel i's centre is at i, KITTI's
//     integer-centre convention, so cx = 620.5 + 0.5 in ours (pixel i's centre at i + 0.5) by
//     default [inferred from those values]; "principal_point": "corner" reads them unshifted.
// No named splits (the dataset has none); a split list names RGB files relative to the root.
// Options: camera (Camera_0 or Camera_1), sequence (SceneXX or SceneXX/<variation>).
#include <ATen/ATen.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/lidar_labels.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/io/atomic_file.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

constexpr double kMetresPerUnit = 1.0 / 100.0;
constexpr double kSky = 65535.0;

// "Scene01/clone", the first two components of an item.
std::string sequence_of(const std::string& item) {
  const std::size_t scene_end = item.find('/');
  return item.substr(0, scene_end == std::string::npos ? scene_end : item.find('/', scene_end + 1));
}

std::string depth_of(const std::string& item) {
  const fs::path path(item);
  const std::string camera = path.parent_path().filename().string();
  const std::string name = path.filename().string();  // rgb_NNNNN.jpg
  return sequence_of(item) + "/frames/depth/" + camera + "/depth_" +
         formats::replace_suffix(name.substr(name.find('_') + 1), ".jpg", ".png");
}

std::string intrinsics_of(const std::string& item) {
  return sequence_of(item) + "/intrinsic.txt";
}

Sample read_frame(const std::string& root, const std::string& item, PrincipalPoint reading) {
  const at::Tensor image = formats::read_rgb(join(root, item));
  const int64_t width = image.size(1), height = image.size(0);
  const fs::path path(item);
  const std::string camera_name = path.parent_path().filename().string();  // Camera_K
  const std::string stem = path.stem().string();                           // rgb_NNNNN
  const int64_t camera_id = std::atoll(camera_name.c_str() + camera_name.find('_') + 1);
  const int64_t frame = std::atoll(stem.c_str() + stem.find('_') + 1);
  const std::string intrinsics_path = join(root, intrinsics_of(item));
  const auto intrinsics =
      formats::parse_vkitti2_intrinsics(io::read_file(intrinsics_path), intrinsics_path);
  const auto k = intrinsics.find({frame, camera_id});
  if (k == intrinsics.end())
    throw std::runtime_error(intrinsics_path + ": no line for frame " + std::to_string(frame) +
                             " of camera " + std::to_string(camera_id));
  const double shift = principal_point_shift(reading);
  const camera::Camera camera =
      camera::make_camera("PINHOLE", width, height,
                          {k->second.fx, k->second.fy, k->second.cx + shift, k->second.cy + shift});
  const at::Tensor code = formats::read_depth_png(join(root, depth_of(item)), 16, 1, width, height);
  return formats::metric_sample(camera, image,
                                formats::distance_from_planar_depth(code * kMetresPerUnit, camera),
                                code != kSky);
}

std::unique_ptr<Dataset> open_vkitti2(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  const std::string camera = formats::option_choice(location, "camera", {"Camera_0", "Camera_1"});
  const PrincipalPoint reading = parse_principal_point(
      option_or(location, "principal_point", "integer-centre"), "option principal_point");
  const std::string pattern = "Scene*/*/frames/rgb/" + camera + "/rgb_*.jpg";
  formats::ItemListing listing;
  listing.found = formats::find_files(root, pattern);
  listing.sequence_of = sequence_of;
  listing.looked_for = pattern;
  formats::ItemReader reader;
  reader.read = [root, reading](const std::string& item) {
    return read_frame(root, item, reading);
  };
  reader.sources = [root](const std::string& item) {
    return std::vector<std::string>{join(root, item), join(root, depth_of(item)),
                                    join(root, intrinsics_of(item))};
  };
  return formats::native_dataset(location, std::move(listing), std::move(reader));
}

}  // namespace

DatasetFormat vkitti2_format() {
  return {"vkitti2",
          "Virtual KITTI 2: Scene*/<variation>/frames/rgb/Camera_K/rgb_*.jpg with "
          "frames/depth/Camera_K/depth_*.png (16-bit cm z-depth, 65535 sky) and intrinsic.txt",
          {{"camera", "Camera_0 (default, left) or Camera_1 (right)"},
           {"sequence", "SceneXX or SceneXX/<variation> (Scene01/clone), comma-separated"},
           {"principal_point",
            "integer-centre (default: intrinsic.txt's cx, cy + 0.5, as its values centre the "
            "image) or corner (unshifted)"}},
          {},
          open_vkitti2};
}

}  // namespace omnipoint::data
