#include "omnipoint/io/rig.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/point_cloud.h"

namespace omnipoint::io {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

// Errors of one rig file: "SOURCE: FIELD: what".
struct RigErrors {
  std::string source;
  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw std::invalid_argument(source + ": " + field + ": " + what);
  }
};

// A 3x4 or 4x4 array of numbers taking sensor coordinates into the body frame, as (4, 4).
at::Tensor parse_transform(const json& rows, const std::string& field, const RigErrors& errors) {
  if (!rows.is_array() || (rows.size() != 3 && rows.size() != 4))
    errors.fail(field, "expected 3 rows of 4 numbers (or 4 rows)");
  at::Tensor matrix = at::eye(4, at::kDouble);
  auto* values = matrix.data_ptr<double>();
  for (size_t r = 0; r < rows.size(); ++r) {
    if (!rows[r].is_array() || rows[r].size() != 4)
      errors.fail(field, "row " + std::to_string(r) + ": expected 4 numbers");
    for (size_t c = 0; c < 4; ++c) {
      const json& value = rows[r][c];
      if (!value.is_number() || !std::isfinite(value.get<double>()))
        errors.fail(field, "row " + std::to_string(r) + ": expected 4 finite numbers");
      values[r * 4 + c] = value.get<double>();
    }
  }
  if (rows.size() == 4 &&
      (values[12] != 0 || values[13] != 0 || values[14] != 0 || values[15] != 1))
    errors.fail(field, "the fourth row must be [0, 0, 0, 1]");
  const at::Tensor rotation = matrix.slice(0, 0, 3).slice(1, 0, 3);
  const double off =
      (rotation.t().mm(rotation) - at::eye(3, at::kDouble)).abs().max().item<double>();
  if (off > kRotationTolerance) {
    char text[96];
    std::snprintf(text, sizeof text, "the rotation is not orthonormal (|R^T R - I| = %.3g)", off);
    errors.fail(field, text);
  }
  if (at::det(rotation).item<double>() < 0)
    errors.fail(field, "the rotation is a reflection (determinant -1)");
  return matrix;
}

bool is_file_name_safe(const std::string& name) {
  if (name.empty() || name.front() == '.') return false;
  for (const char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.')
      return false;
  return true;
}

camera::Camera parse_rig_camera(const json& spec, const std::string& field,
                                const std::string& folder, const RigErrors& errors) {
  if (!spec.is_object() && (!spec.is_string() || spec.get<std::string>().empty()))
    errors.fail(field, "expected a --camera form (a spec, a JSON camera or a file)");
  const std::string text = spec.is_object() ? spec.dump() : spec.get<std::string>();
  try {
    if (spec.is_object() || camera::is_camera_line(text)) return camera::parse_camera(text);
    return read_camera((fs::path(folder) / text).string());
  } catch (const std::invalid_argument& error) {
    errors.fail(field, error.what());
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(errors.source + ": " + field + ": " + error.what());
  }
}

RigCamera parse_camera_entry(const json& entry, size_t index, const std::string& folder,
                             const RigErrors& errors) {
  const std::string field = "cameras[" + std::to_string(index) + "]";
  if (!entry.is_object()) errors.fail(field, "expected an object");
  for (const auto& [key, value] : entry.items())
    if (key != "name" && key != "camera" && key != "body_from_camera")
      errors.fail(field + "." + key, "unknown key (expected name, camera, body_from_camera)");
  for (const char* key : {"name", "camera", "body_from_camera"})
    if (!entry.contains(key)) errors.fail(field + "." + key, "missing");
  if (!entry["name"].is_string() || !is_file_name_safe(entry["name"].get<std::string>()))
    errors.fail(field + ".name",
                "expected letters, digits, '_', '-' or '.' (not first): it names files");
  return RigCamera{entry["name"].get<std::string>(),
                   parse_rig_camera(entry["camera"], field + ".camera", folder, errors),
                   parse_transform(entry["body_from_camera"], field + ".body_from_camera", errors)};
}

RigLidar parse_lidar(const json& entry, const RigErrors& errors) {
  if (!entry.is_object()) errors.fail("lidar", "expected an object");
  for (const auto& [key, value] : entry.items())
    if (key != "format" && key != "body_from_lidar")
      errors.fail("lidar." + key, "unknown key (expected format, body_from_lidar)");
  if (!entry.contains("body_from_lidar")) errors.fail("lidar.body_from_lidar", "missing");
  RigLidar lidar;
  const json format = entry.value("format", json("kitti"));
  if (!format.is_string()) errors.fail("lidar.format", "expected a --lidar-format name");
  lidar.format = format.get<std::string>();
  try {
    lidar.floats_per_point = lidar_floats_per_point(lidar.format);
  } catch (const std::invalid_argument& error) {
    errors.fail("lidar.format", error.what());
  }
  lidar.body_from_lidar =
      parse_transform(entry["body_from_lidar"], "lidar.body_from_lidar", errors);
  return lidar;
}

}  // namespace

const RigCamera* Rig::find(const std::string& name) const {
  for (const RigCamera& camera : cameras)
    if (camera.name == name) return &camera;
  return nullptr;
}

Rig parse_rig(const std::string& text, const std::string& source, const std::string& folder) {
  const RigErrors errors{source};
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& error) {  // a syntax error or a number out of range
    throw std::invalid_argument(source + ": not JSON (" + error.what() + ")");
  }
  if (!root.is_object()) throw std::invalid_argument(source + ": expected a JSON object");
  for (const auto& [key, value] : root.items())
    if (key != "frame" && key != "cameras" && key != "lidar")
      errors.fail(key, "unknown key (expected frame, cameras, lidar)");
  Rig rig;
  if (root.contains("frame")) {
    if (!root["frame"].is_string() || root["frame"].get<std::string>().empty())
      errors.fail("frame", "expected the body frame's name");
    rig.frame = root["frame"].get<std::string>();
  }
  if (!root.contains("cameras") || !root["cameras"].is_array() || root["cameras"].empty())
    errors.fail("cameras", "expected a list of at least one camera");
  std::set<std::string> names;
  for (size_t i = 0; i < root["cameras"].size(); ++i) {
    rig.cameras.push_back(parse_camera_entry(root["cameras"][i], i, folder, errors));
    if (!names.insert(rig.cameras.back().name).second)
      errors.fail("cameras[" + std::to_string(i) + "].name",
                  "'" + rig.cameras.back().name + "' names another camera too");
  }
  if (root.contains("lidar")) rig.lidar = parse_lidar(root["lidar"], errors);
  return rig;
}

Rig read_rig(const std::string& path) {
  return parse_rig(read_file(path), path, fs::path(path).parent_path().string());
}

namespace {

// [[r11, r12, r13, t1], [...], [...]]: the top 3 rows of a (4, 4), doubles as JSON prints
// them (shortest text that reads back exactly).
std::string transform_text(const at::Tensor& matrix) {
  const at::Tensor values = matrix.to(at::kDouble).contiguous();
  if (values.dim() != 2 || values.size(0) != 4 || values.size(1) != 4)
    throw std::invalid_argument("format_rig: a transform is not (4, 4)");
  const double* entries = values.data_ptr<double>();
  std::string text = "[";
  for (std::ptrdiff_t r = 0; r < 3; ++r)
    text +=
        (r ? ", " : "") + json(std::vector<double>(entries + 4 * r, entries + 4 * r + 4)).dump();
  return text + "]";
}

}  // namespace

std::string format_rig(const Rig& rig) {
  std::string text = "{\"frame\": " + json(rig.frame).dump() + ",\n \"cameras\": [";
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const RigCamera& camera = rig.cameras[i];
    text += std::string(i ? "," : "") + "\n  {\"name\": " + json(camera.name).dump() +
            ", \"camera\": " + json(camera.camera.to_spec()).dump() +
            ",\n   \"body_from_camera\": " + transform_text(camera.body_from_camera) + "}";
  }
  text += "]";
  if (rig.lidar)
    text += ",\n \"lidar\": {\"format\": " + json(rig.lidar->format).dump() +
            ", \"body_from_lidar\": " + transform_text(rig.lidar->body_from_lidar) + "}";
  return text + "}\n";
}

void write_rig(const std::string& path, const Rig& rig) {
  const std::string text = format_rig(rig);
  parse_rig(text, path, fs::path(path).parent_path().string());
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

}  // namespace omnipoint::io
