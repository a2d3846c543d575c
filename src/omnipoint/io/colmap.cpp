// The COLMAP model folder: one reader per file, in its format (colmap_text.cpp,
// colmap_binary.cpp), then the links between the files.
#include "omnipoint/io/colmap.h"

#include <ATen/ATen.h>

#include <filesystem>
#include <stdexcept>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/colmap_records.h"

namespace omnipoint::io {
namespace {

using colmap_records::fail;

// The file of `stem` in `folder`: the .bin where there is one, else the .txt.
std::string model_file(const std::string& folder, const std::string& stem, bool& binary) {
  const std::filesystem::path base = std::filesystem::path(folder) / stem;
  for (const bool is_binary : {true, false}) {
    const std::filesystem::path path = base.string() + (is_binary ? ".bin" : ".txt");
    if (std::filesystem::is_regular_file(path)) {
      binary = is_binary;
      return path.string();
    }
  }
  throw std::runtime_error("COLMAP model " + folder + ": no " + stem + ".bin or " + stem + ".txt");
}

}  // namespace

ColmapModel read_colmap_model(const std::string& folder) {
  if (!std::filesystem::is_directory(folder))
    throw std::runtime_error("COLMAP model " + folder + ": not a folder");
  ColmapModel model;
  bool binary = false;
  const std::string cameras = model_file(folder, "cameras", binary);
  model.cameras = binary ? parse_colmap_cameras_binary(read_file(cameras), cameras)
                         : parse_colmap_cameras_text(read_file(cameras), cameras);
  const std::string images = model_file(folder, "images", binary);
  model.images = binary ? parse_colmap_images_binary(read_file(images), images)
                        : parse_colmap_images_text(read_file(images), images);
  const std::string points = model_file(folder, "points3D", binary);
  model.points = binary ? parse_colmap_points_binary(read_file(points), points)
                        : parse_colmap_points_text(read_file(points), points);
  for (const ColmapImage& image : model.images) {
    const std::string where = "image " + std::to_string(image.id) + " (" + image.name + ")";
    if (!model.cameras.count(image.camera_id))
      fail(images, where + " uses camera " + std::to_string(image.camera_id) + ", which " +
                       cameras + " lacks");
    for (const int64_t point : image.point3d_ids)
      if (point != -1 && !model.points.count(point))
        fail(images,
             where + " observes point " + std::to_string(point) + ", which " + points + " lacks");
  }
  return model;
}

at::Tensor camera_from_world(const ColmapImage& image) {
  const auto [w, x, y, z] = image.qvec;
  const auto [tx, ty, tz] = image.tvec;
  return at::tensor({1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y), tx,
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x), ty,
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y), tz, 0.0,
                     0.0, 0.0, 1.0},
                    at::kDouble)
      .view({4, 4});
}

}  // namespace omnipoint::io
