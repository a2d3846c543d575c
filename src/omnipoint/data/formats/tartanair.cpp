// "tartanair": TartanAir (v1) trajectories, as its download zips unpack.
//
// Layout (tartanair_tools data_type.md and README, as vendored by princeton-vl/DROID-SLAM's
// thirdparty/tartanair_tools):
//   ROOT/<env>/<Easy|Hard>/<Pxxx>/image_left/NNNNNN_left.png                 640x480 RGB
//   ROOT/<env>/<Easy|Hard>/<Pxxx>/depth_left/NNNNNN_left_depth.npy           (480, 640) float32
//   (image_right/NNNNNN_right.png, depth_right/NNNNNN_right_depth.npy for option camera=right)
// download_training.py saves the zips as ROOT/<env>/<Easy|Hard>/<kind>_<camera>.zip; their
// inner folders are not documented, so one folder level more above the environment is searched
// too (X/<env>/Easy/P000/...).
// Conventions and their sources:
//   - the camera: fx = fy = 320, cx = 320, cy = 240 at 640x480, 90 degree FoV, the same for
//     every sequence and both cameras (data_type.md). Pixel centres: with the image edges at 0
//     and 640 a 90 degree horizontal FoV gives fx = 320 / tan(45 deg) = 320 exactly and the
//     symmetric frustum of the renderer (AirSim/Unreal) centres the principal point at W/2, H/2:
//     (320, 240) in our convention (pixel i spans [i, i + 1)) as written [inferred from the
//     FoV; the document does not say]. Option principal_point=integer-centre reads (cx, cy)
//     as OpenCV's integer-centre coordinates instead (cx = 320.5 in ours);
//   - depth: metres (data_type.md), float32 (the document says "16-bit"; the files and common
//     loaders are float32, and another dtype is refused naming it), planar z-depth [inferred:
//     data_type.md turns it into disparity as 80 / depth, baseline 0.25 m times fx 320, which
//     holds for z-depth]; turned into distance here;
//   - sky: the environments' sky sphere stores "a large depth value (e.g. 10000)" (data_type.md):
//     depth at or beyond option sky_depth (default 1000 m, a tenth of the sky sphere's and
//     beyond the environments' geometry [inferred]) is no label, as are non-finite and
//     non-positive values.
// Options: camera (left | right), sequence (ENV, ENV/Easy or ENV/Easy/P000, comma-separated).
#include <ATen/ATen.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

constexpr int64_t kWidth = 640, kHeight = 480;
constexpr double kFocal = 320, kCentreX = 320, kCentreY = 240;

struct Settings {
  std::string side = "left";  // the camera
  double centre_shift = 0;    // added to (cx, cy)
  double sky_depth = 1000;    // metres: at or beyond it, sky
};

// SEQUENCE/image_SIDE/NNNNNN_SIDE.png -> SEQUENCE/depth_SIDE/NNNNNN_SIDE_depth.npy.
std::string depth_of(const std::string& item, const std::string& side) {
  const fs::path path(item);
  return (path.parent_path().parent_path() / ("depth_" + side) / path.stem()).generic_string() +
         "_depth.npy";
}

// ENV/LEVEL/Pxxx: the three folders above image_SIDE (whichever root holds them).
std::string sequence_of(const std::string& item) {
  const std::string folder = fs::path(item).parent_path().parent_path().generic_string();
  std::size_t begin = folder.size();
  for (int slashes = 0; slashes < 3 && begin != std::string::npos && begin > 0; ++slashes)
    begin = folder.rfind('/', begin - 1);
  return begin == std::string::npos ? folder : folder.substr(begin + 1);
}

// The array's dtype and shape as NumPy writes them: "float64 (480, 640)".
std::string array_text(const at::Tensor& array) {
  const at::ScalarType type = array.scalar_type();
  std::string text = type == at::kFloat    ? "float32"
                     : type == at::kDouble ? "float64"
                     : type == at::kByte   ? "uint8"
                     : type == at::kInt    ? "int32"
                     : type == at::kLong   ? "int64"
                                           : std::string(c10::toString(type));
  text += " (";
  for (int64_t i = 0; i < array.dim(); ++i) text += (i ? ", " : "") + std::to_string(array.size(i));
  return text + (array.dim() == 1 ? ",)" : ")");
}

Sample read_frame(const std::string& root, const std::string& item, const Settings& settings) {
  const at::Tensor image = formats::read_rgb(join(root, item), kWidth, kHeight);
  const std::string depth_path = join(root, depth_of(item, settings.side));
  const at::Tensor depth = io::read_npy(depth_path);
  if (depth.scalar_type() != at::kFloat || depth.dim() != 2 || depth.size(0) != kHeight ||
      depth.size(1) != kWidth)
    throw std::runtime_error(depth_path + ": expected a float32 (480, 640) array, got " +
                             array_text(depth));
  const camera::Camera camera = camera::make_camera(
      "PINHOLE", kWidth, kHeight,
      {kFocal, kFocal, kCentreX + settings.centre_shift, kCentreY + settings.centre_shift});
  return formats::metric_sample(camera, image, formats::distance_from_planar_depth(depth, camera),
                                depth < settings.sky_depth);
}

std::unique_ptr<Dataset> open_tartanair(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  Settings settings;
  settings.side = formats::option_choice(location, "camera", {"left", "right"});
  settings.centre_shift =
      formats::option_choice(location, "principal_point", {"corner", "integer-centre"}) == "corner"
          ? 0.0
          : 0.5;
  settings.sky_depth = formats::option_number(location, "sky_depth", 1000, 1e-3, 1e9);
  const std::string frames = "P*/image_" + settings.side + "/*_" + settings.side + ".png";
  formats::ItemListing listing;
  listing.found = formats::find_files(root, "*/*/" + frames);
  for (std::string& item : formats::find_files(root, "*/*/*/" + frames))
    listing.found.push_back(std::move(item));
  std::sort(listing.found.begin(), listing.found.end());
  listing.sequence_of = sequence_of;
  listing.looked_for = "<env>/<Easy|Hard>/" + frames;
  const std::string side = settings.side;
  return formats::native_dataset(
      location, std::move(listing),
      formats::image_and_depth_reader(
          root, [side](const std::string& item) { return depth_of(item, side); },
          [settings](const std::string& root, const std::string& item) {
            return read_frame(root, item, settings);
          }));
}

}  // namespace

DatasetFormat tartanair_format() {
  return {"tartanair",
          "TartanAir v1: <env>/<Easy|Hard>/P*/image_left/*_left.png + depth_left/*_left_depth.npy "
          "(float32 m z-depth, sky ~10000), fixed 640x480 pinhole fx=fy=320",
          {{"camera", "left (default) | right"},
           {"sequence", "ENV, ENV/Easy or ENV/Easy/P000, comma-separated"},
           {"sky_depth", "metres: depth at or beyond it is sky, no label (default 1000)"},
           {"principal_point",
            "corner (default: cx, cy = 320, 240 in ours, the symmetric 90 degree frustum) | "
            "integer-centre (cx, cy = 320.5, 240.5)"}},
          {},
          open_tartanair};
}

}  // namespace omnipoint::data
