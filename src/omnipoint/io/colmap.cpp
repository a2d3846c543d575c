#include "omnipoint/io/colmap.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "omnipoint/io/atomic_file.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "COLMAP binary models are read by copying little-endian bytes");

namespace omnipoint::io {
namespace {

[[noreturn]] void fail(const std::string& name, const std::string& what) {
  throw std::invalid_argument("COLMAP " + name + ": " + what);
}

// COLMAP's camera model ids (sensor/models.h) and names.
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

// COLMAP models with no OmniPoint counterpart are an error.
void check_supported(const std::string& model, const std::string& name, const std::string& where) {
  if (model == "SIMPLE_DIVISION" || model == "DIVISION" || model == "SIMPLE_FISHEYE" ||
      model == "FISHEYE")
    fail(name, where + ": COLMAP's camera model " + model +
                   " is not supported by OmniPoint (undistort the images with COLMAP's "
                   "image_undistorter, or choose another model)");
}

// COLMAP's EQUIRECTANGULAR carries the panorama's size as its two parameters.
constexpr size_t kEquirectangularParams = 2;

// A COLMAP camera as ours; `where` names the file and the camera in errors.
camera::Camera colmap_camera(const std::string& model, int64_t width, int64_t height,
                             std::vector<double> params, const std::string& name,
                             const std::string& where) {
  check_supported(model, name, where);
  if (model == "EQUIRECTANGULAR" && params.size() == kEquirectangularParams) {
    if (params[0] != static_cast<double>(width) || params[1] != static_cast<double>(height))
      fail(name, where + ": EQUIRECTANGULAR parameters w h must be the image size " +
                     std::to_string(width) + " " + std::to_string(height));
    params.clear();
  }
  try {
    return camera::Camera(model, width, height, std::move(params));
  } catch (const std::invalid_argument& error) {
    fail(name, where + ": " + error.what());
  }
}

// --- text -----------------------------------------------------------------------------------

template <typename T>
T text_number(const std::string& token, const char* what, const std::string& name,
              const std::string& where) {
  T value{};
  const char* end = token.data() + token.size();
  const auto [stop, error] = std::from_chars(token.data(), end, value);
  if (error != std::errc() || stop != end)
    fail(name, where + ": " + what + " '" + token + "' is not " +
                   (std::is_integral_v<T> ? "an integer" : "a number"));
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) fail(name, where + ": " + what + " is not finite");
  }
  return value;
}

int64_t text_id(const std::string& token, const char* what, const std::string& name,
                const std::string& where) {
  const int64_t id = text_number<int64_t>(token, what, name, where);
  if (id < 0) fail(name, where + ": " + what + " " + token + " is negative");
  return id;
}

std::vector<std::string> words_of(const std::string& line) {
  std::istringstream stream(line);
  std::vector<std::string> words;
  for (std::string word; stream >> word;) words.push_back(word);
  return words;
}

// The lines of a text file with their numbers; blank and '#' lines are skipped by `next_data`.
class TextLines {
 public:
  explicit TextLines(const std::string& text) : stream_(text) {}
  // The next line that is neither blank nor a comment; false at the end.
  bool next_data(std::string& line) {
    while (next(line)) {
      const size_t first = line.find_first_not_of(" \t");
      if (first != std::string::npos && line[first] != '#') return true;
    }
    return false;
  }
  // The very next line, whatever it holds; false at the end.
  bool next(std::string& line) {
    if (!std::getline(stream_, line)) return false;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    ++number_;
    return true;
  }
  std::string where() const { return "line " + std::to_string(number_); }

 private:
  std::istringstream stream_;
  int64_t number_ = 0;
};

// --- binary ---------------------------------------------------------------------------------

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

// --- shared checks --------------------------------------------------------------------------

// Normalises the quaternion; zero or non-finite ones are errors.
void normalise_quaternion(ColmapImage& image, const std::string& name) {
  double norm = 0;
  for (const double q : image.qvec) norm += q * q;
  norm = std::sqrt(norm);
  if (!(norm > 0) || !std::isfinite(norm))
    fail(name, "image " + std::to_string(image.id) + ": the quaternion is zero or not finite");
  for (double& q : image.qvec) q /= norm;
}

void check_finite(const double* values, size_t count, const std::string& what,
                  const std::string& name) {
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) fail(name, what + " is not finite");
}

void add_image(std::vector<ColmapImage>& images, std::set<int64_t>& ids, ColmapImage image,
               const std::string& name) {
  check_finite(image.qvec.data(), 4, "image " + std::to_string(image.id) + "'s quaternion", name);
  check_finite(image.tvec.data(), 3, "image " + std::to_string(image.id) + "'s translation", name);
  normalise_quaternion(image, name);
  if (!ids.insert(image.id).second)
    fail(name, "the image id " + std::to_string(image.id) + " appears twice");
  images.push_back(std::move(image));
}

void add_camera(std::map<int64_t, camera::Camera>& cameras, int64_t id, camera::Camera camera,
                const std::string& name) {
  if (!cameras.emplace(id, std::move(camera)).second)
    fail(name, "the camera id " + std::to_string(id) + " appears twice");
}

void add_point(std::map<int64_t, ColmapPoint>& points, int64_t id, const ColmapPoint& point,
               const std::string& name) {
  check_finite(point.xyz.data(), 3, "point " + std::to_string(id) + "'s position", name);
  if (!std::isfinite(point.error))
    fail(name, "point " + std::to_string(id) + "'s error is not finite");
  if (!points.emplace(id, point).second)
    fail(name, "the point id " + std::to_string(id) + " appears twice");
}

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

std::map<int64_t, camera::Camera> parse_colmap_cameras_text(const std::string& text,
                                                            const std::string& name) {
  std::map<int64_t, camera::Camera> cameras;
  TextLines lines(text);
  for (std::string line; lines.next_data(line);) {
    const std::vector<std::string> words = words_of(line);
    const std::string where = lines.where();
    if (words.size() < 4) fail(name, where + ": expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    const int64_t id = text_id(words[0], "camera id", name, where);
    std::vector<double> params;
    for (size_t i = 4; i < words.size(); ++i)
      params.push_back(text_number<double>(words[i], "parameter", name, where));
    add_camera(cameras, id,
               colmap_camera(words[1], text_number<int64_t>(words[2], "width", name, where),
                             text_number<int64_t>(words[3], "height", name, where),
                             std::move(params), name, where + " (camera " + words[0] + ")"),
               name);
  }
  return cameras;
}

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

std::vector<ColmapImage> parse_colmap_images_text(const std::string& text,
                                                  const std::string& name) {
  std::vector<ColmapImage> images;
  std::set<int64_t> ids;
  TextLines lines(text);
  for (std::string line; lines.next_data(line);) {
    const std::string where = lines.where();
    std::istringstream stream(line);
    std::vector<std::string> words(9);
    for (std::string& word : words) stream >> word;
    std::string image_name;
    std::getline(stream, image_name);
    const size_t first = image_name.find_first_not_of(" \t");
    const size_t last = image_name.find_last_not_of(" \t");
    if (words[8].empty() || first == std::string::npos)
      fail(name, where + ": expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    ColmapImage image;
    image.id = text_id(words[0], "image id", name, where);
    for (int i = 0; i < 4; ++i)
      image.qvec[i] = text_number<double>(words[1 + i], "quaternion value", name, where);
    for (int i = 0; i < 3; ++i)
      image.tvec[i] = text_number<double>(words[5 + i], "translation value", name, where);
    image.camera_id = text_id(words[8], "camera id", name, where);
    // The rest of the line, so that names with spaces (which COLMAP writes) read back.
    image.name = image_name.substr(first, last + 1 - first);
    std::string observations;
    if (!lines.next(observations))
      fail(name, where + ": image " + words[0] +
                     " has no POINTS2D line after it (an empty line when it has none)");
    const std::vector<std::string> values = words_of(observations);
    if (values.size() % 3 != 0)
      fail(name, lines.where() + ": POINTS2D holds " + std::to_string(values.size()) +
                     " values, not triples X Y POINT3D_ID");
    for (size_t i = 0; i < values.size(); i += 3) {
      image.points2d.push_back({text_number<double>(values[i], "X", name, lines.where()),
                                text_number<double>(values[i + 1], "Y", name, lines.where())});
      const int64_t point = text_number<int64_t>(values[i + 2], "POINT3D_ID", name, lines.where());
      if (point < -1)
        fail(name, lines.where() + ": POINT3D_ID " + values[i + 2] + " (expected -1 or an id)");
      image.point3d_ids.push_back(point);
    }
    add_image(images, ids, std::move(image), name);
  }
  return images;
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

std::map<int64_t, ColmapPoint> parse_colmap_points_text(const std::string& text,
                                                        const std::string& name) {
  std::map<int64_t, ColmapPoint> points;
  TextLines lines(text);
  for (std::string line; lines.next_data(line);) {
    const std::string where = lines.where();
    const std::vector<std::string> words = words_of(line);
    if (words.size() < 8 || words.size() % 2 != 0)
      fail(name, where +
                     ": expected POINT3D_ID X Y Z R G B ERROR TRACK[] as (IMAGE_ID, "
                     "POINT2D_IDX) pairs");
    const int64_t id = text_id(words[0], "point id", name, where);
    ColmapPoint point;
    for (int i = 0; i < 3; ++i)
      point.xyz[i] = text_number<double>(words[1 + i], "X Y Z", name, where);
    for (int i = 0; i < 3; ++i) {
      const int64_t channel = text_number<int64_t>(words[4 + i], "colour", name, where);
      if (channel < 0 || channel > 255)
        fail(name, where + ": colour " + words[4 + i] + " is not 0..255");
      point.rgb[i] = static_cast<uint8_t>(channel);
    }
    point.error = text_number<double>(words[7], "error", name, where);
    for (size_t i = 8; i < words.size(); ++i) text_id(words[i], "track entry", name, where);
    add_point(points, id, point, name);
  }
  return points;
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
