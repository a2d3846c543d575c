#include "omnipoint/data/formats/native_text.h"

#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace omnipoint::data::formats {
namespace {

[[noreturn]] void fail(const std::string& source, int line, const std::string& why) {
  throw std::runtime_error(source + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                           why);
}

// A whole field as a finite number (std::stod accepts leading blanks and trailing text; we
// do not).
bool to_number(const std::string& text, double& value) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
  std::size_t used = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == text.size() && std::isfinite(value);
}

double number(const std::string& text, const std::string& source, int line,
              const std::string& what) {
  double value = 0;
  if (!to_number(text, value)) fail(source, line, what + " \"" + text + "\" is not a number");
  return value;
}

// The whitespace-separated words of each non-blank line, with line numbers.
std::vector<std::pair<int, std::vector<std::string>>> word_lines(const std::string& text) {
  std::vector<std::pair<int, std::vector<std::string>>> lines;
  std::istringstream stream(text);
  int number = 0;
  for (std::string line; std::getline(stream, line);) {
    ++number;
    std::istringstream words(line);
    std::vector<std::string> fields;
    for (std::string word; words >> word;) fields.push_back(word);
    if (!fields.empty()) lines.emplace_back(number, std::move(fields));
  }
  return lines;
}

// A whole field as an integer in [0, 2^53] (a float that is one, "1024.0", included).
int64_t whole_number(const std::string& text, const std::string& source, int line,
                     const std::string& what) {
  const double value = number(text, source, line, what);
  if (value < 0 || value > 9007199254740992.0 || value != std::floor(value))
    fail(source, line, what + " \"" + text + "\" is not a non-negative integer");
  return static_cast<int64_t>(value);
}

// A CSV file without quoting (Hypersim's metadata): the header's column names, then the rows,
// each of the header's field count, with their line numbers. Blank lines are skipped.
struct CsvTable {
  std::map<std::string, std::size_t> columns;
  std::vector<std::pair<int, std::vector<std::string>>> rows;
};
CsvTable parse_csv(const std::string& text, const std::string& source) {
  CsvTable table;
  std::istringstream stream(text);
  int number = 0;
  std::size_t width = 0;
  for (std::string line; std::getline(stream, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (line.find('"') != std::string::npos) fail(source, number, "quoted fields are not read");
    std::vector<std::string> fields;
    std::size_t start = 0;
    for (std::size_t comma; (comma = line.find(',', start)) != std::string::npos; start = comma + 1)
      fields.push_back(line.substr(start, comma - start));
    fields.push_back(line.substr(start));
    if (width == 0) {
      width = fields.size();
      for (std::size_t i = 0; i < fields.size(); ++i)
        if (!table.columns.emplace(fields[i], i).second)
          fail(source, number, "the column " + fields[i] + " appears twice");
      continue;
    }
    if (fields.size() != width)
      fail(source, number,
           "expected " + std::to_string(width) + " fields (as the header), got " +
               std::to_string(fields.size()));
    table.rows.emplace_back(number, std::move(fields));
  }
  if (width == 0) fail(source, 0, "no header line");
  return table;
}

// The index of column `name` (missing -> an error naming it).
std::size_t column(const CsvTable& table, const std::string& name, const std::string& source) {
  const auto found = table.columns.find(name);
  if (found == table.columns.end()) fail(source, 1, "no column " + name);
  return found->second;
}

}  // namespace

Structured3dPose parse_structured3d_pose(const std::string& text, const std::string& source) {
  const auto lines = word_lines(text);
  if (lines.size() != 1 || lines.front().second.size() != 12)
    fail(source, 0, "expected one line of 12 numbers (vx vy vz tx ty tz ux uy uz xfov yfov 1)");
  const auto& [line, f] = lines.front();
  double v[12];
  for (int i = 0; i < 12; ++i) v[i] = number(f[i], source, line, "field " + std::to_string(i + 1));
  Structured3dPose pose;
  for (int i = 0; i < 3; ++i) {
    pose.eye[i] = v[i];
    pose.toward[i] = v[3 + i];
    pose.up[i] = v[6 + i];
  }
  pose.half_fov_x = v[9];
  pose.half_fov_y = v[10];
  const auto half_fov_ok = [](double angle) { return angle > 0 && angle < M_PI / 2; };
  if (!half_fov_ok(pose.half_fov_x) || !half_fov_ok(pose.half_fov_y))
    fail(source, line, "xfov and yfov must be half-angles in (0, pi/2) radians");
  return pose;
}

std::map<std::pair<int64_t, int64_t>, PinholeIntrinsics> parse_vkitti2_intrinsics(
    const std::string& text, const std::string& source) {
  const auto lines = word_lines(text);
  if (lines.empty() || lines.front().second.front() != "frame")
    fail(source, 0, "expected the header line \"frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\"");
  std::map<std::pair<int64_t, int64_t>, PinholeIntrinsics> intrinsics;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto& [line, f] = lines[i];
    if (f.size() != 6)
      fail(source, line,
           "expected 6 fields (frame cameraID fx fy cx cy), got " + std::to_string(f.size()));
    const int64_t frame = whole_number(f[0], source, line, "frame");
    const int64_t camera = whole_number(f[1], source, line, "cameraID");
    const PinholeIntrinsics k{number(f[2], source, line, "fx"), number(f[3], source, line, "fy"),
                              number(f[4], source, line, "cx"), number(f[5], source, line, "cy")};
    if (k.fx <= 0 || k.fy <= 0) fail(source, line, "fx and fy must be > 0");
    if (!intrinsics.emplace(std::pair{frame, camera}, k).second)
      fail(source, line, "frame " + f[0] + " of camera " + f[1] + " is given twice");
  }
  return intrinsics;
}

std::map<std::string, HypersimCamera> parse_hypersim_cameras(const std::string& text,
                                                             const std::string& source) {
  const CsvTable table = parse_csv(text, source);
  const std::size_t scene = column(table, "scene_name", source);
  const std::size_t width = column(table, "settings_output_img_width", source);
  const std::size_t height = column(table, "settings_output_img_height", source);
  std::array<std::size_t, 9> matrix{};
  for (int i = 0; i < 9; ++i)
    matrix[i] =
        column(table, "M_cam_from_uv_" + std::to_string(i / 3) + std::to_string(i % 3), source);
  std::map<std::string, HypersimCamera> cameras;
  for (const auto& [line, f] : table.rows) {
    HypersimCamera camera;
    camera.width = whole_number(f[width], source, line, "settings_output_img_width");
    camera.height = whole_number(f[height], source, line, "settings_output_img_height");
    if (camera.width < 1 || camera.height < 1 || camera.width > 65535 || camera.height > 65535)
      fail(source, line, "the image size must lie in [1, 65535]");
    for (int i = 0; i < 9; ++i)
      camera.cam_from_uv[i] =
          number(f[matrix[i]], source, line,
                 "M_cam_from_uv_" + std::to_string(i / 3) + std::to_string(i % 3));
    if (f[scene].empty()) fail(source, line, "no scene_name");
    if (!cameras.emplace(f[scene], camera).second)
      fail(source, line, "the scene " + f[scene] + " appears twice");
  }
  return cameras;
}

std::map<HypersimFrame, std::string> parse_hypersim_split(const std::string& text,
                                                          const std::string& source) {
  const CsvTable table = parse_csv(text, source);
  const std::size_t scene = column(table, "scene_name", source);
  const std::size_t camera = column(table, "camera_name", source);
  const std::size_t frame = column(table, "frame_id", source);
  const std::size_t included = column(table, "included_in_public_release", source);
  const std::size_t partition = column(table, "split_partition_name", source);
  std::map<HypersimFrame, std::string> split;
  for (const auto& [line, f] : table.rows) {
    if (f[included] != "True" && f[included] != "False")
      fail(source, line,
           "included_in_public_release \"" + f[included] + "\" is neither True nor False");
    if (f[included] == "False") continue;
    const std::string& name = f[partition];
    if (name != "train" && name != "val" && name != "test")
      fail(source, line, "split_partition_name \"" + name + "\" is not train, val or test");
    HypersimFrame key{f[scene], f[camera], whole_number(f[frame], source, line, "frame_id")};
    if (!split.emplace(std::move(key), name).second)
      fail(source, line,
           "the frame " + f[scene] + " " + f[camera] + " " + f[frame] + " appears twice");
  }
  return split;
}

Pincam parse_pincam(const std::string& text, const std::string& source) {
  const auto lines = word_lines(text);
  if (lines.size() != 1 || lines.front().second.size() != 6)
    fail(source, 0, "expected one line of 6 numbers (width height fx fy cx cy)");
  const auto& [line, f] = lines.front();
  static const char* const names[] = {"width", "height", "fx", "fy", "cx", "cy"};
  double v[6];
  for (int i = 0; i < 6; ++i) v[i] = number(f[i], source, line, names[i]);
  for (int i = 0; i < 2; ++i)
    if (v[i] != std::floor(v[i]) || v[i] < 1 || v[i] > 100000)
      fail(source, line,
           std::string(names[i]) + " \"" + f[i] +
               "\" is not a whole number of pixels in [1, 100000]");
  if (v[2] <= 0 || v[3] <= 0) fail(source, line, "fx and fy must be positive");
  return {static_cast<int64_t>(v[0]), static_cast<int64_t>(v[1]), v[2], v[3], v[4], v[5]};
}

}  // namespace omnipoint::data::formats
