// "hypersim": Apple's Hypersim renderings, each frame's colour with its distance image.
//
// Layout (ml-hypersim README, apple/ml-hypersim @c85b287):
//   ROOT/ai_VVV_NNN/images/scene_cam_XX_final_hdf5/frame.IIII.color.hdf5          HDR colour
//   ROOT/ai_VVV_NNN/images/scene_cam_XX_final_preview/frame.IIII.tonemap.jpg      its preview
//   ROOT/ai_VVV_NNN/images/scene_cam_XX_geometry_hdf5/frame.IIII.depth_meters.hdf5
//   ROOT/ai_VVV_NNN/images/scene_cam_XX_geometry_hdf5/frame.IIII.render_entity_id.hdf5
//   ROOT/metadata_camera_parameters.csv      (the repository's contrib/mikeroberts3000/; option
//                                             camera_csv names another path)
//   ROOT/metadata_images_split_scene_v1.csv  (the repository's evermotion_dataset/analysis/;
//                                             option split_csv; read for the named splits)
// Conventions and their sources:
//   - every HDF5 file holds one array named "dataset" (float16 colours and distances, int16
//     entity ids: code/python/tools/generate_hdf5_from_vrimg.py);
//   - depth_meters is the distance from the camera's centre in metres, not a planar depth (README;
//     the maintainer in issue #9); NaN where no surface was hit (issue #63): no label;
//   - rays: metadata_camera_parameters.csv's M_cam_from_uv maps (u, v, 1) to a ray in Hypersim's
//     camera frame (x right, y up, z backwards), u and v in NDC at pixel centres, u = -1 + (i +
//     0.5) 2 / W left to right and v = 1 - (j + 0.5) 2 / H top to bottom (notebook 01, whose
//     rays were checked against depth_meters with a ray caster); in our pixel convention (pixel
//     i's centre at i + 0.5) u = 2 x / W - 1, v = 1 - 2 y / H;
//   - the camera: that map, with our axes (y, z negated), is inverse(K) up to a rotation R and a
//     positive scale, K upper triangular (the RQ decomposition). Without skew, K is our PINHOLE
//     exactly, in the frame of the image plane. Of the CSV's 482 scenes, for the 194 standard
//     ones and the 14 with a shifted principal point R is the identity (the sample's frame is
//     Hypersim's camera frame); the tilts of V-Ray's tilt-shift lens turn the image plane of 243
//     (by up to 41.5 degrees), and the sample's frame is Hypersim's turned by R (distances along
//     each pixel's ray are the same in both; poses are not read). 31 scenes that tilt about two
//     axes at once keep a skew (up to 8.9 pixels) that no camera model of ours has: they are
//     left out (option tilt_shift=exclude also leaves out the turned ones); a split list naming
//     one of their frames is an error;
//   - colour ("color"): "hdf5" (default) tone-maps color.hdf5 as the dataset's own
//     code/python/tools/scene_generate_images_tonemap.py makes the previews, without their JPEG
//     loss: brightness 0.3 R + 0.59 G + 0.11 B over the pixels whose render_entity_id is not -1,
//     scale = 0.8^2.2 / its 90th percentile (NumPy's linear interpolation; 0 below 1e-4, 1 when
//     no pixel is valid), colour = clip((scale rgb)^(1/2.2), 0, 1) (non-finite -> 0); "preview"
//     reads the tonemap.jpg written by that script.
// Named splits: train, val, test (metadata_images_split_scene_v1.csv's split_partition_name of
// the frames included in the public release). Option "sequence": ai_VVV_NNN or
// ai_VVV_NNN/cam_XX.
#include <ATen/ATen.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "omnipoint/data/dataset_formats.h"
#include "omnipoint/data/formats/hdf5_array.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/io/atomic_file.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using formats::join;
using Matrix = std::array<std::array<double, 3>, 3>;

// A pinhole is exact when dropping the skew moves no pixel by more than this (pixels).
constexpr double kExactPixels = 1e-3;

// The camera of a scene: PINHOLE in the frame of its image plane, how far that frame is turned
// from Hypersim's camera frame (radians) and the skew (pixels) a PINHOLE leaves out.
struct SceneCamera {
  std::array<double, 4> pinhole{};  // fx fy cx cy
  int64_t width = 0, height = 0;
  double turn = 0;
  double skew_pixels = 0;
  bool exact() const { return skew_pixels <= kExactPixels; }
  bool turned() const { return turn * std::max(pinhole[0], pinhole[1]) > kExactPixels; }
};

Matrix multiply(const Matrix& a, const Matrix& b) {
  Matrix c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// The inverse of a 3x3 matrix (its adjugate over its determinant); singular -> throws.
Matrix inverse(const Matrix& m, const std::string& what) {
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (!std::isfinite(det) || std::abs(det) < 1e-300)
    throw std::runtime_error(what + ": M_cam_from_uv is singular");
  Matrix r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      r[i][j] = (m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]) / det;
    }
  return r;
}

SceneCamera scene_camera(const formats::HypersimCamera& row, const std::string& what) {
  const double w = static_cast<double>(row.width), h = static_cast<double>(row.height);
  Matrix m{};
  for (int i = 0; i < 9; ++i) m[i / 3][i % 3] = row.cam_from_uv[i];
  // Our pixel (x, y, 1) -> (u, v, 1), and Hypersim's axes -> ours (y and z negated).
  const Matrix uv_from_pixel{{{2 / w, 0, -1}, {0, -2 / h, 1}, {0, 0, 1}}};
  const Matrix ours_from_hypersim{{{1, 0, 0}, {0, -1, 0}, {0, 0, -1}}};
  const Matrix rays = multiply(ours_from_hypersim, multiply(m, uv_from_pixel));
  // rays = R^T inverse(K) / s, so inverse(rays) = s K R: its RQ decomposition, row by row from
  // the last (Gram-Schmidt on the rows), gives K (upper triangular, positive diagonal) and R.
  const Matrix n = inverse(rays, what);
  std::array<std::array<double, 3>, 3> q{};  // R's rows
  Matrix k{};
  for (int row_index = 2; row_index >= 0; --row_index) {
    std::array<double, 3> rest = n[row_index];
    for (int later = row_index + 1; later < 3; ++later) {
      k[row_index][later] = dot(n[row_index], q[later]);
      for (int a = 0; a < 3; ++a) rest[a] -= k[row_index][later] * q[later][a];
    }
    k[row_index][row_index] = std::sqrt(dot(rest, rest));
    for (int a = 0; a < 3; ++a) q[row_index][a] = rest[a] / k[row_index][row_index];
  }
  const double det_q =
      dot(q[0], {q[1][1] * q[2][2] - q[1][2] * q[2][1], q[1][2] * q[2][0] - q[1][0] * q[2][2],
                 q[1][0] * q[2][1] - q[1][1] * q[2][0]});
  if (det_q < 0) throw std::runtime_error(what + ": M_cam_from_uv mirrors the image");
  SceneCamera camera;
  camera.width = row.width;
  camera.height = row.height;
  const double scale = k[2][2];
  camera.pinhole = {k[0][0] / scale, k[1][1] / scale, k[0][2] / scale, k[1][2] / scale};
  // x = fx X + skew Y + cx: dropping the skew moves a pixel by |skew| |Y|, |Y| <= the image's
  // farthest row from cy over fy.
  const double farthest = std::max(camera.pinhole[3], h - camera.pinhole[3]) / camera.pinhole[1];
  camera.skew_pixels = std::abs(k[0][1] / scale) * farthest;
  camera.turn = std::acos(std::clamp((q[0][0] + q[1][1] + q[2][2] - 1) / 2, -1.0, 1.0));
  return camera;
}

// numpy.percentile's default (linear interpolation between the sorted values' ranks).
double percentile(const at::Tensor& values, double percent) {
  const at::Tensor sorted = std::get<0>(values.to(at::kDouble).sort());
  const double rank = percent / 100 * static_cast<double>(sorted.numel() - 1);
  const auto low = static_cast<int64_t>(std::floor(rank));
  const int64_t high = std::min<int64_t>(low + 1, sorted.numel() - 1);
  const double a = sorted[low].item<double>(), b = sorted[high].item<double>();
  return a + (b - a) * (rank - static_cast<double>(low));
}

// scene_generate_images_tonemap.py's tone mapping (the header).
at::Tensor tonemap(const at::Tensor& rgb, const at::Tensor& valid) {
  constexpr double kGamma = 1 / 2.2, kPercentile = 90, kBrightness = 0.8, kDarkest = 1e-4;
  double scale = 1;
  if (valid.any().item<bool>()) {
    const at::Tensor brightness =
        0.3 * rgb.select(-1, 0) + 0.59 * rgb.select(-1, 1) + 0.11 * rgb.select(-1, 2);
    const double current = percentile(brightness.masked_select(valid), kPercentile);
    scale = current < kDarkest ? 0.0 : std::pow(kBrightness, 1 / kGamma) / current;
  }
  const at::Tensor mapped = (rgb * scale).clamp_min(0).pow(kGamma).clamp(0, 1);
  return at::where(at::isfinite(mapped), mapped, at::zeros_like(mapped)).contiguous();
}

// The parts of an item's path .../ai_VVV_NNN/images/scene_cam_XX_final_hdf5/frame.IIII.color.hdf5.
struct ItemParts {
  std::string scene, camera, frame_file;  // ai_VVV_NNN, cam_XX, frame.IIII
};
ItemParts parts_of(const std::string& item) {
  const fs::path path(item);
  const std::string folder = path.parent_path().filename().string();  // scene_cam_XX_final_...
  const std::string scene = path.parent_path().parent_path().parent_path().filename().string();
  const std::string name = path.filename().string();
  // scene_cam_XX_final_hdf5 or scene_cam_XX_final_preview -> cam_XX
  const std::size_t end = folder.rfind("_final");
  const std::string camera = folder.rfind("scene_", 0) == 0 && end != std::string::npos && end > 6
                                 ? folder.substr(6, end - 6)
                                 : folder;
  return {scene, camera, name.substr(0, name.find('.', 6))};
}

std::string geometry_file(const std::string& item, const std::string& kind) {
  const ItemParts parts = parts_of(item);
  return parts.scene + "/images/scene_" + parts.camera + "_geometry_hdf5/" + parts.frame_file +
         "." + kind + ".hdf5";
}

struct Settings {
  bool preview = false;  // colour from tonemap.jpg
  std::string camera_csv;
  std::shared_ptr<const std::map<std::string, formats::HypersimCamera>> cameras;
};

Sample read_frame(const std::string& root, const std::string& item, const Settings& settings) {
  const std::string scene = parts_of(item).scene;
  const auto row = settings.cameras->find(scene);
  if (row == settings.cameras->end())
    throw std::runtime_error(settings.camera_csv + ": no row for the scene " + scene);
  const SceneCamera geometry = scene_camera(row->second, settings.camera_csv + " " + scene);
  if (!geometry.exact())
    throw std::runtime_error(settings.camera_csv + ": the scene " + scene +
                             "'s tilt-shift camera has a skew (of up to " +
                             std::to_string(geometry.skew_pixels) +
                             " pixels) that no camera model of ours has (such scenes are left out "
                             "of the listing)");
  const camera::Camera camera =
      camera::make_camera("PINHOLE", geometry.width, geometry.height,
                          std::vector<double>(geometry.pinhole.begin(), geometry.pinhole.end()));
  const std::string depth_path = join(root, geometry_file(item, "depth_meters"));
  const at::Tensor distance = formats::read_hdf5_array(depth_path, "dataset", at::kFloat);
  if (distance.dim() != 2)
    throw std::runtime_error(depth_path + ": expected a 2-D distance image, got " +
                             std::to_string(distance.dim()) + " dimensions");
  formats::expect_size(distance, geometry.width, geometry.height, depth_path,
                       "the camera (" + settings.camera_csv + ")");
  at::Tensor image;
  if (settings.preview) {
    image = formats::read_rgb(join(root, item), geometry.width, geometry.height);
  } else {
    const std::string color_path = join(root, item);
    const at::Tensor rgb = formats::read_hdf5_array(color_path, "dataset", at::kFloat);
    if (rgb.dim() != 3 || rgb.size(2) != 3)
      throw std::runtime_error(color_path + ": expected an (H, W, 3) colour image");
    formats::expect_size(rgb, geometry.width, geometry.height, color_path,
                         "the camera (" + settings.camera_csv + ")");
    const std::string id_path = join(root, geometry_file(item, "render_entity_id"));
    const at::Tensor ids = formats::read_hdf5_array(id_path, "dataset", at::kInt);
    if (ids.dim() != 2)
      throw std::runtime_error(id_path + ": expected a 2-D entity id image, got " +
                               std::to_string(ids.dim()) + " dimensions");
    formats::expect_size(ids, geometry.width, geometry.height, id_path, color_path);
    image = tonemap(rgb, ids != -1);
  }
  return formats::metric_sample(camera, std::move(image), distance, at::isfinite(distance));
}

// "ai_001_001/cam_00", the sequence key of an item.
std::string sequence_of(const std::string& item) {
  const ItemParts parts = parts_of(item);
  return parts.scene + "/" + parts.camera;
}

std::unique_ptr<Dataset> open_hypersim(const DatasetLocation& location) {
  formats::require_root(location);
  const std::string root = location.path;
  Settings settings;
  settings.preview = formats::option_choice(location, "color", {"hdf5", "preview"}) == "preview";
  const bool exclude_turned =
      formats::option_choice(location, "tilt_shift", {"rotate", "exclude"}) == "exclude";
  settings.camera_csv =
      option_or(location, "camera_csv", join(root, "metadata_camera_parameters.csv"));
  settings.cameras = std::make_shared<const std::map<std::string, formats::HypersimCamera>>(
      formats::parse_hypersim_cameras(io::read_file(settings.camera_csv), settings.camera_csv));

  const std::string pattern = settings.preview
                                  ? "ai_*/images/scene_cam_*_final_preview/frame.*.tonemap.jpg"
                                  : "ai_*/images/scene_cam_*_final_hdf5/frame.*.color.hdf5";
  formats::ItemListing listing;
  // Scenes with no exact camera of ours are not listed (the header); scenes missing from the
  // CSV are, and fail when read.
  std::map<std::string, bool> listed;  // scene -> listed
  for (std::string& item : formats::find_files(root, pattern)) {
    const std::string scene = parts_of(item).scene;
    if (!listed.count(scene)) {
      const auto row = settings.cameras->find(scene);
      bool keep = true;
      if (row != settings.cameras->end()) {
        const SceneCamera geometry = scene_camera(row->second, settings.camera_csv + " " + scene);
        keep = geometry.exact() && !(exclude_turned && geometry.turned());
      }
      listed[scene] = keep;
    }
    if (listed[scene]) listing.found.push_back(std::move(item));
  }
  listing.sequence_of = sequence_of;
  listing.looked_for = pattern;
  listing.split_names = {"train", "val", "test"};
  std::shared_ptr<const std::map<formats::HypersimFrame, std::string>> split;
  if (location.split == "train" || location.split == "val" || location.split == "test") {
    const std::string split_csv =
        option_or(location, "split_csv", join(root, "metadata_images_split_scene_v1.csv"));
    split = std::make_shared<const std::map<formats::HypersimFrame, std::string>>(
        formats::parse_hypersim_split(io::read_file(split_csv), split_csv));
  }
  listing.in_split = [split](const std::string& name, const std::string& item) {
    const ItemParts parts = parts_of(item);
    const std::string digits = parts.frame_file.substr(parts.frame_file.find('.') + 1);
    const auto found = split->find({parts.scene, parts.camera, std::atoll(digits.c_str())});
    return found != split->end() && found->second == name;
  };
  formats::ItemReader reader;
  reader.read = [root, settings](const std::string& item) {
    return read_frame(root, item, settings);
  };
  reader.sources = [root, preview = settings.preview](const std::string& item) {
    std::vector<std::string> files{join(root, item),
                                   join(root, geometry_file(item, "depth_meters"))};
    if (!preview) files.push_back(join(root, geometry_file(item, "render_entity_id")));
    return files;
  };
  return formats::native_dataset(location, std::move(listing), std::move(reader));
}

}  // namespace

DatasetFormat hypersim_format() {
  return {"hypersim",
          "Hypersim renderings: ai_*/images/scene_cam_*_final_hdf5/frame.*.color.hdf5 (HDR, "
          "tone-mapped) with scene_cam_*_geometry_hdf5/frame.*.depth_meters.hdf5 (distance, NaN "
          "missing); ROOT/metadata_camera_parameters.csv (M_cam_from_uv); libhdf5",
          {{"sequence", "ai_VVV_NNN or ai_VVV_NNN/cam_XX, comma-separated"},
           {"color",
            "hdf5 (default: color.hdf5 tone-mapped as the dataset's previews) or preview "
            "(scene_cam_*_final_preview/frame.*.tonemap.jpg)"},
           {"tilt_shift",
            "rotate (default: a tilted image plane's exact pinhole, in its own frame; the 31 "
            "scenes whose tilt leaves a skew are left out) or exclude (only scenes "
            "whose pinhole is in Hypersim's camera frame)"},
           {"camera_csv", "metadata_camera_parameters.csv (default: ROOT/ holds it)"},
           {"split_csv",
            "metadata_images_split_scene_v1.csv for the named splits (default: ROOT/ holds it)"}},
          {"train", "val", "test"},
          open_hypersim};
}

}  // namespace omnipoint::data
