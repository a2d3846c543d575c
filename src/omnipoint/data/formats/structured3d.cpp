// "structured3d": Structured3D's renderings, panoramas (the default) or perspective views.
//
// Layout (data_organization.md, bertjiazheng/Structured3D @a1aa97f):
//   ROOT/scene_<id>/2D_rendering/<room>/panorama/<empty|simple|full>/rgb_<cold|raw|warm>light.png
//                                                                  /depth.png
//   ROOT/scene_<id>/2D_rendering/<room>/perspective/<empty|full>/<position>/rgb_rawlight.png,
//                                                              depth.png, camera_pose.txt
// Conventions:
//   - depth: 16-bit grey PNG in millimetres ("a value of 1000 is a meter"); 0 = no reading
//     (data_organization.md);
//   - panoramas: full equirectangular images, zenith on top (native.h), their depth the
//     distance from the camera [inferred: the dataset's issue #9 back-projects it as distance
//     times the unit sphere's ray; the documentation does not say];
//   - perspective views: camera_pose.txt "vx vy vz tx ty tz ux uy uz xfov yfov 1" with xfov,
//     yfov the half-angles "from the central ray to the leftmost/bottommost ray"
//     (data_organization.md), i.e. to the image's edges; the principal point is the image's
//     centre (misc/utils.py: K[0][2] = W / 2): PINHOLE W H fx fy W/2 H/2 with
//     fx = (W/2) / tan(xfov), fy = (H/2) / tan(yfov), exact in our pixel convention (edges at
//     0 and W); their depth is z-depth by default [unverified: not documented; renderers'
//     perspective depth is a z-buffer] (option perspective_depth=distance for the other reading).
// Named splits (README): train = scenes 00000-02999, val = 03000-03249, test = 03250-03499.
// Options: view (panorama | perspective), furniture (full | simple | empty), lighting (raw |
// cold | warm; perspective views are rawlight only), sequence (scene_<id> or
// scene_<id>/2D_rendering/<room>).
#include <ATen/ATen.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/io/atomic_file.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

constexpr double kMetresPerUnit = 1.0 / 1000.0;

std::string scene_of(const std::string& item) {
  return item.substr(0, item.find('/'));
}

std::string in_folder(const std::string& item, const std::string& file) {
  return fs::path(item).parent_path().generic_string() + "/" + file;
}

bool in_split(const std::string& split, const std::string& item) {
  const std::string scene = scene_of(item);  // scene_NNNNN
  if (scene.size() != 11 || scene.compare(0, 6, "scene_") != 0) return false;
  const int id = std::atoi(scene.c_str() + 6);
  if (split == "train") return id < 3000;
  if (split == "val") return id >= 3000 && id < 3250;
  return id >= 3250 && id < 3500;
}

camera::Camera perspective_camera(const std::string& pose_path, int64_t width, int64_t height) {
  const formats::Structured3dPose pose =
      formats::parse_structured3d_pose(io::read_file(pose_path), pose_path);
  const double cx = 0.5 * static_cast<double>(width), cy = 0.5 * static_cast<double>(height);
  return camera::make_camera(
      "PINHOLE", width, height,
      {cx / std::tan(pose.half_fov_x), cy / std::tan(pose.half_fov_y), cx, cy});
}

struct Settings {
  bool perspective = false;
  bool depth_is_z = true;  // perspective views
};

Sample read_view(const std::string& root, const std::string& item, const Settings& settings) {
  const at::Tensor image = formats::read_rgb(join(root, item));
  const int64_t width = image.size(1), height = image.size(0);
  const at::Tensor code =
      formats::read_depth_png(join(root, in_folder(item, "depth.png")), 16, 1, width, height);
  const at::Tensor metres = code * kMetresPerUnit;
  if (!settings.perspective)
    return formats::metric_sample(formats::full_panorama(width, height), image, metres, code > 0);
  const camera::Camera camera =
      perspective_camera(join(root, in_folder(item, "camera_pose.txt")), width, height);
  const at::Tensor distance =
      settings.depth_is_z ? formats::distance_from_planar_depth(metres, camera) : metres;
  return formats::metric_sample(camera, image, distance, code > 0);
}

std::unique_ptr<Dataset> open_structured3d(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  Settings settings;
  settings.perspective =
      formats::option_choice(location, "view", {"panorama", "perspective"}) == "perspective";
  settings.depth_is_z =
      formats::option_choice(location, "perspective_depth", {"z", "distance"}) == "z";
  const std::string furniture =
      formats::option_choice(location, "furniture", {"full", "simple", "empty"});
  const std::string lighting =
      formats::option_choice(location, "lighting", {"raw", "cold", "warm"});
  if (settings.perspective && (furniture == "simple" || lighting != "raw"))
    throw std::invalid_argument(
        "structured3d: perspective views are rendered full or empty, with raw light only");
  const std::string pattern =
      settings.perspective
          ? "scene_*/2D_rendering/*/perspective/" + furniture + "/*/rgb_rawlight.png"
          : "scene_*/2D_rendering/*/panorama/" + furniture + "/rgb_" + lighting + "light.png";
  formats::ItemListing listing;
  listing.found = formats::find_files(root, pattern);
  listing.sequence_of = [](const std::string& item) { return item; };
  listing.looked_for = pattern;
  listing.split_names = {"train", "val", "test"};
  listing.in_split = in_split;
  formats::ItemReader reader;
  reader.read = [root, settings](const std::string& item) {
    return read_view(root, item, settings);
  };
  reader.sources = [root, settings](const std::string& item) {
    std::vector<std::string> files{join(root, item), join(root, in_folder(item, "depth.png"))};
    if (settings.perspective) files.push_back(join(root, in_folder(item, "camera_pose.txt")));
    return files;
  };
  return formats::native_dataset(location, std::move(listing), std::move(reader));
}

}  // namespace

DatasetFormat structured3d_format() {
  return {"structured3d",
          "Structured3D renderings: scene_*/2D_rendering/<room>/panorama/<furniture>/"
          "rgb_<light>light.png + depth.png (16-bit mm, 0 missing), or perspective/ views with "
          "camera_pose.txt",
          {{"sequence", "scene_<id> (or scene_<id>/2D_rendering/<room>), comma-separated"},
           {"view", "panorama | perspective (default panorama)"},
           {"furniture", "full | simple | empty (default full; perspective: full or empty)"},
           {"lighting", "raw | cold | warm (default raw; perspective: raw)"},
           {"perspective_depth",
            "z | distance: what a perspective view's depth.png holds (default z, unverified)"}},
          {"train", "val", "test"},
          open_structured3d};
}

}  // namespace omnipoint::data
