// "arkitscenes": ARKitScenes' raw subset (its frames with depth), as download_data.py unpacks it.
//
// Layout (apple/ARKitScenes: DATA.md, raw/README.md, download_data.py @2140a5b):
//   ROOT/<Training|Validation>/<video_id>/lowres_wide/<video_id>_<timestamp>.png      RGB
//   ROOT/<Training|Validation>/<video_id>/lowres_depth/<video_id>_<timestamp>.png     depth
//   ROOT/<Training|Validation>/<video_id>/lowres_wide_intrinsics/<video_id>_<timestamp>.pincam
// (ROOT is download_data.py's DOWNLOAD_DIR/raw.) The 256x192 "lowres" assets are the 60 FPS
// stream with the iPad's LiDAR depth; option resolution=highres reads the 1920x1440 "wide" RGB,
// "highres_depth" (projected from the Faro laser-scanner mesh, videos of the upsampling subset)
// and "wide_intrinsics" instead. The timestamp is written with 3 decimals ("6845.873").
// Conventions and their sources:
//   - depth: 16-bit grey PNG in millimetres (DATA.md), 0 = no reading (the devkit's d != 0
//     filter, threedod/benchmark_scripts/utils/tenFpsDataLoader.py::generate_point);
//   - depth is planar (camera-frame z): generate_point back-projects K^-1 [u d, v d, d];
//     turned into distance here (native.h: distance_from_planar_depth);
//   - .pincam "width height fx fy cx cy" (DATA.md; native_text.h). Pixel centres: the devkit
//     back-projects pixel (u, v) at the integer coordinates u, v, so (cx, cy) are in the
//     integer-centre convention and cx = cx_pincam + 0.5 in ours (pixel i spans [i, i + 1)).
//     That is the default; option principal_point=corner takes (cx, cy) as written;
//   - a frame's .pincam may carry a timestamp 0.001 off its image's (rounding): the devkit
//     (tenFpsDataLoader.py) tries the timestamp, then it - 0.001, then it + 0.001; so do we;
//   - not every timestamp has every asset (raw/README.md: "no guarantee that all assets exist
//     per timestamp"): the items are the frames with a depth map, as the devkit lists them
//     (lowres_depth/*.png), each read with the RGB image of the same name;
//   - images may be stored turned by 90 degrees (metadata.csv's sky direction): the camera is
//     that of the image as stored, so its geometry is right; gravity is not made upright.
//   - the confidence maps and the .traj poses are not read.
// Named splits: train (Training/), val (Validation/). Option sequence: video ids.
#include <ATen/ATen.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/io/atomic_file.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;

constexpr double kMetresPerUnit = 1.0 / 1000.0;

// The three folders of one resolution.
struct Assets {
  std::string rgb, depth, intrinsics;
};

struct Settings {
  Assets assets;
  double centre_shift = 0.5;  // added to the .pincam's (cx, cy)
};

// FOLD/VIDEO/FOLDER/NAME: the path's components.
std::string component(const std::string& item, int index) {
  std::size_t begin = 0;
  for (int i = 0; i < index; ++i) begin = item.find('/', begin) + 1;
  return item.substr(begin, item.find('/', begin) - begin);
}

std::string video_of(const std::string& item) {
  return component(item, 1);
}

// The item's file of the same name in another asset folder, with extension `extension`.
std::string sibling(const std::string& item, const std::string& folder,
                    const std::string& extension) {
  const fs::path path(item);
  return (path.parent_path().parent_path() / folder / path.stem()).generic_string() + extension;
}

// The .pincam of an item: its own timestamp's, else the one 0.001 s before or after (the
// devkit's order); none existing -> its own name (reported missing).
std::string pincam_of(const std::string& root, const std::string& item, const Assets& assets) {
  std::string exact = sibling(item, assets.intrinsics, ".pincam");
  std::error_code error;
  if (fs::exists(join(root, exact), error)) return exact;
  const std::string stem = fs::path(item).stem().string();  // VIDEO_TIMESTAMP
  const std::size_t underscore = stem.rfind('_');
  if (underscore == std::string::npos) return exact;
  char* end = nullptr;
  const double timestamp = std::strtod(stem.c_str() + underscore + 1, &end);
  if (end != stem.c_str() + stem.size() || !std::isfinite(timestamp)) return exact;
  for (const double offset : {-0.001, 0.001}) {
    char text[64];
    std::snprintf(text, sizeof text, "%.3f", timestamp + offset);
    std::string nearby =
        (fs::path(exact).parent_path() / (stem.substr(0, underscore + 1) + text + ".pincam"))
            .generic_string();
    if (fs::exists(join(root, nearby), error)) return nearby;
  }
  return exact;
}

Sample read_frame(const std::string& root, const std::string& item, const Settings& settings) {
  const std::string pincam_path = join(root, pincam_of(root, item, settings.assets));
  const formats::Pincam pincam = formats::parse_pincam(io::read_file(pincam_path), pincam_path);
  const camera::Camera camera = camera::make_camera(
      "PINHOLE", pincam.width, pincam.height,
      {pincam.fx, pincam.fy, pincam.cx + settings.centre_shift, pincam.cy + settings.centre_shift});
  const std::string image_path = join(root, item);
  const at::Tensor image = formats::read_rgb(image_path);
  formats::expect_size(image, pincam.width, pincam.height, image_path, pincam_path);
  const at::Tensor code = formats::read_depth_png(
      join(root, sibling(item, settings.assets.depth, ".png")), 16, 1, pincam.width, pincam.height);
  return formats::metric_sample(
      camera, image, formats::distance_from_planar_depth(code * kMetresPerUnit, camera), code > 0);
}

std::unique_ptr<Dataset> open_arkitscenes(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  Settings settings;
  settings.assets =
      formats::option_choice(location, "resolution", {"lowres", "highres"}) == "lowres"
          ? Assets{"lowres_wide", "lowres_depth", "lowres_wide_intrinsics"}
          : Assets{"wide", "highres_depth", "wide_intrinsics"};
  settings.centre_shift = formats::option_choice(location, "principal_point",
                                                 {"integer-centre", "corner"}) == "integer-centre"
                              ? 0.5
                              : 0.0;
  const Assets& assets = settings.assets;
  formats::ItemListing listing;
  for (const std::string& depth : formats::find_files(root, "*/*/" + assets.depth + "/*_*.png"))
    listing.found.push_back(sibling(depth, assets.rgb, ".png"));
  listing.sequence_of = video_of;
  listing.looked_for = "*/<video_id>/" + assets.depth + "/<video_id>_<timestamp>.png";
  listing.split_names = {"train", "val"};
  listing.in_split = [](const std::string& split, const std::string& item) {
    return component(item, 0) == (split == "train" ? "Training" : "Validation");
  };
  formats::ItemReader reader;
  reader.read = [root, settings](const std::string& item) {
    return read_frame(root, item, settings);
  };
  reader.sources = [root, assets](const std::string& item) {
    return std::vector<std::string>{join(root, item),
                                    join(root, sibling(item, assets.depth, ".png")),
                                    join(root, pincam_of(root, item, assets))};
  };
  return formats::native_dataset(location, std::move(listing), std::move(reader));
}

}  // namespace

DatasetFormat arkitscenes_format() {
  return {"arkitscenes",
          "ARKitScenes raw frames: <Training|Validation>/<video_id>/lowres_wide/*.png + "
          "lowres_depth/ (16-bit mm z-depth, 0 missing) + lowres_wide_intrinsics/*.pincam",
          {{"sequence", "video ids, comma-separated"},
           {"resolution",
            "lowres (default: lowres_wide, the iPad's LiDAR lowres_depth) | highres (wide, the "
            "laser scanner's highres_depth, wide_intrinsics)"},
           {"principal_point",
            "integer-centre (default: the devkit's, cx = cx_pincam + 0.5 in ours) | corner"}},
          {"train", "val"},
          open_arkitscenes};
}

}  // namespace omnipoint::data
