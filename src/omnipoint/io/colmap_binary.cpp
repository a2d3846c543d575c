// COLMAP's binary format (reconstruction_io_binary.cc): cameras.bin, images.bin, points3D.bin,
// little-endian.
#include <cmath>
#include <cstring>
#include <limits>
#include <set>
#include <utility>

#include "omnipoint/io/colmap.h"
#include "omnipoint/io/colmap_records.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "COLMAP binary models are read by copying little-endian bytes");

namespace omnipoint::io {
namespace {

using colmap_records::add_camera;
using colmap_records::add_image;
using colmap_records::add_point;
using colmap_records::check_supported;
using colmap_records::colmap_camera;
using colmap_records::fail;
using colmap_records::kEquirectangularParams;

// COLMAP's camera model names in the order of its model ids (sensor/models.h).
const std::vector<std::string>& colmap_model_names() {
  static const std::vector<std::string> names = {"SIMPLE_PINHOLE",
                                                 "PINHOLE",
                                                 "SIMPLE_RADIAL",
                                                 "RADIAL",
                                                 "OPENCV",
                                                 "OPENCV_FISHEYE",
                                                 "FULL_OPENCV",
                                                 "FOV",
                                                 "SIMPLE_RADIAL_FISHEYE",
                                                 "RADIAL_FISHEYE",
                                                 "THIN_PRISM_FISHEYE",
                                                 "RAD_TAN_THIN_PRISM_FISHEYE",
                                                 "SIMPLE_DIVISION",
                                                 "DIVISION",
                                                 "SIMPLE_FISHEYE",
                                                 "FISHEYE",
                                                 "EUCM",
                                                 "EQUIRECTANGULAR"};
  return names;
}

class BinaryReader {
 public:
  BinaryReader(const std::string& bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  template <typename T>
  T next(const std::string& what) {
    if (bytes_.size() - at_ < sizeof(T))
      fail(name_, "truncated: " + what + " at byte " + std::to_string(at_) + " of " +
                      std::to_string(bytes_.size()));
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  double next_finite(const std::string& what) {
    const double value = next<double>(what);
    if (!std::isfinite(value)) fail(name_, what + " is not finite");
    return value;
  }
  // A uint64 count of items of at least `item_bytes` bytes each, which must fit in the rest.
  uint64_t count(const std::string& what, uint64_t item_bytes) {
    const uint64_t value = next<uint64_t>("the number of " + what);
    if (value > (bytes_.size() - at_) / item_bytes)
      fail(name_, std::to_string(value) + " " + what + " declared at byte " +
                      std::to_string(at_ - 8) + ", more than the " +
                      std::to_string(bytes_.size() - at_) + " bytes left hold");
    return value;
  }
  // A NUL-terminated string.
  std::string text(const std::string& what) {
    const size_t end = bytes_.find('\0', at_);
    if (end == std::string::npos)
      fail(name_, "truncated: " + what + " has no terminating NUL byte");
    std::string value = bytes_.substr(at_, end - at_);
    at_ = end + 1;
    return value;
  }
  void skip(uint64_t bytes) { at_ += bytes; }  // within a count() already checked
  void expect_end() const {
    if (at_ != bytes_.size())
      fail(name_, std::to_string(bytes_.size() - at_) + " bytes after the last record");
  }

 private:
  const std::string& bytes_;
  const std::string& name_;
  size_t at_ = 0;
};

// A binary id (uint32 or uint64) as int64.
int64_t binary_id(uint64_t id, const std::string& what, const std::string& name) {
  if (id > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()))
    fail(name, what + " " + std::to_string(id) + " is out of range");
  return static_cast<int64_t>(id);
}

}  // namespace

std::map<int64_t, camera::Camera> parse_colmap_cameras_binary(const std::string& bytes,
                                                              const std::string& name) {
  std::map<int64_t, camera::Camera> cameras;
  BinaryReader reader(bytes, name);
  // camera_id uint32, model_id int32, width uint64, height uint64, then the parameters.
  const uint64_t count = reader.count("cameras", 24);
  for (uint64_t i = 0; i < count; ++i) {
    const std::string what = "camera " + std::to_string(i);
    const int64_t id = reader.next<uint32_t>(what + "'s id");
    const std::string where = "camera " + std::to_string(id);
    const int32_t model_id = reader.next<int32_t>(where + "'s model id");
    const uint64_t width = reader.next<uint64_t>(where + "'s width");
    const uint64_t height = reader.next<uint64_t>(where + "'s height");
    const auto& names = colmap_model_names();
    if (model_id < 0 || model_id >= static_cast<int32_t>(names.size()))
      fail(name, where + ": unknown COLMAP camera model id " + std::to_string(model_id) +
                     " (OmniPoint knows ids 0.." + std::to_string(names.size() - 1) + ")");
    const std::string& model = names[model_id];
    check_supported(model, name, where);
    const size_t param_count = model == "EQUIRECTANGULAR"
                                   ? kEquirectangularParams
                                   : camera::find_camera_model(model).param_names().size();
    std::vector<double> params;
    for (size_t p = 0; p < param_count; ++p)
      params.push_back(reader.next<double>(where + "'s parameter " + std::to_string(p)));
    add_camera(
        cameras, id,
        colmap_camera(model, binary_id(width, where + "'s width", name),
                      binary_id(height, where + "'s height", name), std::move(params), name, where),
        name);
  }
  reader.expect_end();
  return cameras;
}

std::vector<ColmapImage> parse_colmap_images_binary(const std::string& bytes,
                                                    const std::string& name) {
  std::vector<ColmapImage> images;
  std::set<int64_t> ids;
  BinaryReader reader(bytes, name);
  // id uint32, 7 doubles, camera id uint32, a name of at least its NUL, a uint64 count.
  const uint64_t count = reader.count("images", 4 + 7 * 8 + 4 + 1 + 8);
  for (uint64_t i = 0; i < count; ++i) {
    ColmapImage image;
    image.id = reader.next<uint32_t>("image " + std::to_string(i) + "'s id");
    const std::string where = "image " + std::to_string(image.id);
    for (double& q : image.qvec) q = reader.next<double>(where + "'s quaternion");
    for (double& t : image.tvec) t = reader.next<double>(where + "'s translation");
    image.camera_id = reader.next<uint32_t>(where + "'s camera id");
    image.name = reader.text(where + "'s name");
    // x, y double and a uint64 point id each.
    const uint64_t observations = reader.count(where + "'s points2D", 24);
    image.points2d.reserve(observations);
    image.point3d_ids.reserve(observations);
    for (uint64_t j = 0; j < observations; ++j) {
      const double x = reader.next_finite(where + "'s point2D " + std::to_string(j));
      const double y = reader.next_finite(where + "'s point2D " + std::to_string(j));
      image.points2d.push_back({x, y});
      const uint64_t point = reader.next<uint64_t>(where + "'s point3D id");
      image.point3d_ids.push_back(point == std::numeric_limits<uint64_t>::max()
                                      ? -1
                                      : binary_id(point, where + "'s point3D id", name));
    }
    add_image(images, ids, std::move(image), name);
  }
  reader.expect_end();
  return images;
}

std::map<int64_t, ColmapPoint> parse_colmap_points_binary(const std::string& bytes,
                                                          const std::string& name) {
  std::map<int64_t, ColmapPoint> points;
  BinaryReader reader(bytes, name);
  // id uint64, xyz 3 doubles, rgb 3 bytes, error double, track length uint64.
  const uint64_t count = reader.count("points", 8 + 24 + 3 + 8 + 8);
  for (uint64_t i = 0; i < count; ++i) {
    const int64_t id =
        binary_id(reader.next<uint64_t>("point " + std::to_string(i) + "'s id"), "point id", name);
    const std::string where = "point " + std::to_string(id);
    ColmapPoint point;
    for (double& x : point.xyz) x = reader.next<double>(where + "'s position");
    for (uint8_t& channel : point.rgb) channel = reader.next<uint8_t>(where + "'s colour");
    point.error = reader.next<double>(where + "'s error");
    // Track entries: image id and point2D index, uint32 each.
    reader.skip(8 * reader.count(where + "'s track entries", 8));
    add_point(points, id, point, name);
  }
  reader.expect_end();
  return points;
}

}  // namespace omnipoint::io
