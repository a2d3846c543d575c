// The KITTI raw and KITTI-360 text parsers of kitti_text.h.
#include "omnipoint/data/formats/kitti_text.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "omnipoint/io/keyed_text.h"

namespace omnipoint::data {
namespace {

[[noreturn]] void fail(const std::string& name, const std::string& problem) {
  throw std::invalid_argument(name + ": " + problem);
}

// A whole token as a finite double, or nothing.
bool to_number(const std::string& token, double& value) {
  std::size_t used = 0;
  try {
    value = std::stod(token, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == token.size() && std::isfinite(value);
}

// 3x4 row-major numbers -> (4, 4) float64 with the row (0, 0, 0, 1).
at::Tensor rigid_4x4(const std::vector<double>& values) {
  at::Tensor matrix = at::eye(4, at::kDouble);
  matrix.narrow(0, 0, 3).copy_(at::tensor(values, at::kDouble).view({3, 4}));
  return matrix;
}

// A size "W H" given as numbers (KITTI writes 1.242000e+03 3.750000e+02).
camera::ImageSize image_size(const std::vector<double>& values, const std::string& name,
                             const std::string& key) {
  const double width = values[0], height = values[1];
  if (!(width >= 1 && height >= 1 && width <= 1e6 && height <= 1e6) || width != std::floor(width) ||
      height != std::floor(height))
    fail(name, key + ": expected a whole image size, got " + std::to_string(width) + " " +
                   std::to_string(height));
  return {static_cast<int64_t>(width), static_cast<int64_t>(height)};
}

// A rectified projection P = K [I | t] (3x4 row-major): the PINHOLE camera of K at `size`, and t.
struct Projection {
  camera::Camera camera;
  std::array<double, 3> t;
};
Projection rectified_projection(const std::vector<double>& p, camera::ImageSize size,
                                PrincipalPoint reading, const std::string& name,
                                const std::string& key) {
  const double fx = p[0], skew = p[1], cx = p[2], fy = p[5], cy = p[6];
  if (p[4] != 0 || p[8] != 0 || p[9] != 0 || p[10] != 1 || skew != 0)
    fail(name, key + ": expected a rectified projection [fx 0 cx tx; 0 fy cy ty; 0 0 1 tz]");
  const double shift = principal_point_shift(reading);
  try {
    camera::Camera camera("PINHOLE", size.width, size.height, {fx, fy, cx + shift, cy + shift});
    // K t = P[:, 3]: t_z = P23, then t_y, t_x.
    const double tz = p[11], ty = (p[7] - cy * tz) / fy, tx = (p[3] - cx * tz) / fx;
    return {camera, {tx, ty, tz}};
  } catch (const std::invalid_argument& e) {
    fail(name, key + ": " + e.what());
  }
}

// OpenCV FileStorage YAML as the KITTI-360 devkit reads it (helpers/project.py readYAMLFile:
// the "%YAML:1.0" line skipped, "key:value" read as "key: value"): top-level "key: value"
// lines, and sections "name:" whose indented "key: value" lines become "name.key".
std::map<std::string, std::string> read_opencv_yaml(const std::string& text,
                                                    const std::string& name) {
  std::map<std::string, std::string> values;
  std::string section;
  std::istringstream lines(text);
  int64_t number = 0;
  for (std::string line; std::getline(lines, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line.compare(first, 5, "%YAML") == 0 ||
        line.compare(first, 3, "---") == 0)
      continue;
    const std::size_t colon = line.find(':', first);
    if (colon == std::string::npos)
      fail(name, "line " + std::to_string(number) + " \"" + line.substr(0, 60) +
                     "\" is not \"key: value\"");
    std::string key = line.substr(first, colon - first);
    key.erase(key.find_last_not_of(" \t") + 1);
    std::string value = line.substr(colon + 1);
    const std::size_t begin = value.find_first_not_of(" \t");
    value = begin == std::string::npos ? "" : value.substr(begin);
    value.erase(value.find_last_not_of(" \t") + 1);
    if (key.empty() || key.find_first_of(" \t") != std::string::npos)
      fail(name, "line " + std::to_string(number) + " has no single key before ':'");
    if (first == 0) {
      section = value.empty() ? key : "";
      if (value.empty()) continue;
    } else if (section.empty()) {
      fail(name, "line " + std::to_string(number) + ": an indented key outside a section");
    } else {
      key = section + "." + key;
    }
    if (!values.emplace(key, value).second) fail(name, "the key " + key + " appears twice");
  }
  return values;
}

}  // namespace

void check_kitti_camera_name(const std::string& camera, const std::string& what) {
  if (camera != "image_00" && camera != "image_01" && camera != "image_02" && camera != "image_03")
    throw std::invalid_argument(what + ": camera \"" + camera +
                                "\": expected image_00, image_01, image_02 or image_03");
}

camera::Camera parse_kitti360_fisheye(const std::string& text, const std::string& name,
                                      PrincipalPoint reading, bool tangential) {
  const std::map<std::string, std::string> values = read_opencv_yaml(text, name);
  const auto text_of = [&](const std::string& key) {
    const auto found = values.find(key);
    if (found == values.end()) fail(name, "no key " + key);
    return found->second;
  };
  const auto number = [&](const std::string& key) {
    double value = 0;
    if (!to_number(text_of(key), value))
      fail(name, key + ": \"" + text_of(key).substr(0, 40) + "\" is not a number");
    return value;
  };
  if (text_of("model_type") != "MEI")
    fail(name, "model_type \"" + text_of("model_type").substr(0, 40) +
                   "\": only MEI (the KITTI-360 fisheyes' model) is read");
  const double width = number("image_width"), height = number("image_height");
  const camera::ImageSize size = image_size({width, height}, name, "image_width/image_height");
  const double shift = principal_point_shift(reading);
  const double p1 = number("distortion_parameters.p1"), p2 = number("distortion_parameters.p2");
  try {
    return camera::Camera(
        "MEI", size.width, size.height,
        {number("projection_parameters.gamma1"), number("projection_parameters.gamma2"),
         number("projection_parameters.u0") + shift, number("projection_parameters.v0") + shift,
         number("mirror_parameters.xi"), number("distortion_parameters.k1"),
         number("distortion_parameters.k2"), tangential ? p1 : 0.0, tangential ? p2 : 0.0});
  } catch (const std::invalid_argument& e) {
    fail(name, e.what());
  }
}

Kitti360Perspective parse_kitti360_perspective(const std::string& text, const std::string& name,
                                               const std::string& camera_name,
                                               PrincipalPoint reading) {
  if (camera_name != "image_00" && camera_name != "image_01")
    fail(name, "camera " + camera_name + " is no perspective camera (image_00, image_01)");
  const std::string index = camera_name.substr(6);
  const io::KeyedText keyed = io::KeyedText::parse(text, name);
  const camera::ImageSize size =
      image_size(keyed.numbers("S_rect_" + index, 2), name, "S_rect_" + index);
  const Projection projection = rectified_projection(keyed.numbers("P_rect_" + index, 12), size,
                                                     reading, name, "P_rect_" + index);
  at::Tensor rect = at::eye(4, at::kDouble);
  rect.narrow(0, 0, 3).narrow(1, 0, 3).copy_(
      at::tensor(keyed.numbers("R_rect_" + index, 9), at::kDouble).view({3, 3}));
  return {projection.camera, rect};
}

std::map<std::string, at::Tensor> parse_kitti360_cam_to_pose(const std::string& text,
                                                             const std::string& name) {
  const io::KeyedText keyed = io::KeyedText::parse(text, name);
  std::map<std::string, at::Tensor> transforms;
  for (const std::string& key : keyed.keys()) {
    check_kitti_camera_name(key, name);
    transforms[key] = rigid_4x4(keyed.numbers(key, 12));
  }
  if (!transforms.count("image_00")) fail(name, "no key image_00");
  return transforms;
}

at::Tensor parse_kitti360_cam_to_velo(const std::string& text, const std::string& name) {
  std::istringstream words(text);
  std::vector<double> values;
  for (std::string token; words >> token;) {
    double value = 0;
    if (!to_number(token, value)) fail(name, "\"" + token.substr(0, 40) + "\" is not a number");
    values.push_back(value);
  }
  if (values.size() != 12)
    fail(name, "expected 12 numbers (a 3x4 camera-to-Velodyne transform), got " +
                   std::to_string(values.size()));
  return rigid_4x4(values);
}

std::map<int64_t, at::Tensor> parse_kitti360_poses(const std::string& text,
                                                   const std::string& name) {
  std::map<int64_t, at::Tensor> poses;
  std::istringstream lines(text);
  int64_t number = 0;
  for (std::string line; std::getline(lines, line);) {
    ++number;
    std::istringstream words(line);
    std::vector<double> values;
    for (std::string token; words >> token;) {
      double value = 0;
      if (!to_number(token, value))
        fail(name, "line " + std::to_string(number) + ": \"" + token.substr(0, 40) +
                       "\" is not a number");
      values.push_back(value);
    }
    if (values.empty()) continue;
    if (values.size() != 13)
      fail(name, "line " + std::to_string(number) +
                     ": expected 13 numbers (frame, 3x4 pose), got " +
                     std::to_string(values.size()));
    if (!(values[0] >= 0 && values[0] < 1e12) || values[0] != std::floor(values[0]))
      fail(name, "line " + std::to_string(number) + ": the frame is no index");
    const auto frame = static_cast<int64_t>(values[0]);
    if (!poses.emplace(frame, rigid_4x4({values.begin() + 1, values.end()})).second)
      fail(name, "frame " + std::to_string(frame) + " appears twice");
  }
  return poses;
}

KittiRawCamera parse_kitti_raw_camera(const std::string& text, const std::string& name,
                                      const std::string& camera_name, PrincipalPoint reading) {
  check_kitti_camera_name(camera_name, name);
  const std::string index = camera_name.substr(6);
  const io::KeyedText keyed = io::KeyedText::parse(text, name);
  const camera::ImageSize size =
      image_size(keyed.numbers("S_rect_" + index, 2), name, "S_rect_" + index);
  const Projection projection = rectified_projection(keyed.numbers("P_rect_" + index, 12), size,
                                                     reading, name, "P_rect_" + index);
  at::Tensor rect = at::eye(4, at::kDouble);
  rect.narrow(0, 0, 3).narrow(1, 0, 3).copy_(
      at::tensor(keyed.numbers("R_rect_00", 9), at::kDouble).view({3, 3}));
  at::Tensor offset = at::eye(4, at::kDouble);
  offset.narrow(0, 0, 3).select(1, 3).copy_(
      at::tensor(std::vector<double>(projection.t.begin(), projection.t.end()), at::kDouble));
  return {projection.camera, at::matmul(offset, rect)};
}

// Calls `line(number, tokens)` for each line of a split list that holds a word (1-based numbers).
template <typename Line>
void for_each_list_line(const std::string& text, const Line& line) {
  std::istringstream lines(text);
  int64_t number = 0;
  for (std::string row; std::getline(lines, row);) {
    ++number;
    std::istringstream words(row);
    std::vector<std::string> tokens;
    for (std::string token; words >> token;) tokens.push_back(token);
    if (!tokens.empty()) line(number, tokens);
  }
}

std::vector<Kitti360ListEntry> parse_kitti360_list(const std::string& text,
                                                   const std::string& name) {
  std::vector<Kitti360ListEntry> entries;
  for_each_list_line(text, [&](int64_t number, const std::vector<std::string>& tokens) {
    double focal = 0;
    if (tokens.size() > 3 || (tokens.size() == 3 && !to_number(tokens[2], focal)))
      fail(name, "line " + std::to_string(number) +
                     ": expected \"IMAGE [DEPTH [FOCAL]]\" (DAC's list form)");
    entries.push_back({number, tokens[0], tokens.size() > 1 ? tokens[1] : ""});
  });
  if (entries.empty()) fail(name, "the list names no frame");
  return entries;
}

std::vector<KittiRawListEntry> parse_kitti_raw_list(const std::string& text,
                                                    const std::string& name) {
  std::vector<KittiRawListEntry> entries;
  for_each_list_line(text, [&](int64_t number, const std::vector<std::string>& tokens) {
    const auto bad = [&](const std::string& why) {
      fail(name, "line " + std::to_string(number) + ": " + why +
                     " (expected \"DATE/DRIVE FRAME [l|r]\")");
    };
    if (tokens.size() < 2 || tokens.size() > 3) bad("expected 2 or 3 fields");
    KittiRawListEntry entry;
    entry.line = number;
    entry.drive = tokens[0];
    if (entry.drive.find("..") != std::string::npos) bad("the drive leaves the root");
    double frame = 0;
    if (!to_number(tokens[1], frame) || frame < 0 || frame >= 1e10 || frame != std::floor(frame))
      bad("\"" + tokens[1].substr(0, 20) + "\" is no frame index");
    entry.frame = static_cast<int64_t>(frame);
    if (tokens.size() == 3) {
      if (tokens[2] != "l" && tokens[2] != "r") bad("the side must be l or r");
      entry.camera = tokens[2] == "l" ? "image_02" : "image_03";
    }
    entries.push_back(entry);
  });
  if (entries.empty()) fail(name, "the list names no frame");
  return entries;
}

}  // namespace omnipoint::data
