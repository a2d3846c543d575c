// COLMAP's text format (reconstruction_io_text.cc): cameras.txt, images.txt, points3D.txt.
#include <charconv>
#include <cmath>
#include <set>
#include <sstream>
#include <type_traits>
#include <utility>

#include "omnipoint/io/colmap.h"
#include "omnipoint/io/colmap_records.h"

namespace omnipoint::io {
namespace {

using colmap_records::add_camera;
using colmap_records::add_image;
using colmap_records::add_point;
using colmap_records::colmap_camera;
using colmap_records::fail;

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

}  // namespace omnipoint::io
