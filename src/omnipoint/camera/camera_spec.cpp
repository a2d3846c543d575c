// Camera specs: COLMAP cameras.txt lines and files, JSON objects and files (forms in camera.h).
#include <nlohmann/json.hpp>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/unik3d.h"

namespace omnipoint::camera {
namespace {

std::vector<std::string> split_whitespace(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> tokens;
  for (std::string token; in >> token;) tokens.push_back(token);
  return tokens;
}

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

bool is_model_name(const std::string& token) {
  if (token.empty() || !std::isalpha(static_cast<unsigned char>(token[0]))) return false;
  for (const char c : token) {
    if (!(std::isupper(static_cast<unsigned char>(c)) ||
          std::isdigit(static_cast<unsigned char>(c)) || c == '_'))
      return false;
  }
  return true;
}

bool is_integer(const std::string& token) {
  if (token.empty()) return false;
  std::size_t used = 0;
  try {
    std::stoll(token, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == token.size();
}

int64_t parse_size(const std::string& token, const std::string& what, const std::string& model) {
  if (!is_integer(token)) {
    throw std::invalid_argument(model + ": image " + what + " must be an integer, got '" + token +
                                "'");
  }
  return std::stoll(token);
}

double parse_number(const std::string& token, const std::string& model, std::size_t index) {
  // strtod accepts "nan" and "inf"; they are rejected as non-finite by the Camera.
  char* end = nullptr;
  const double value = std::strtod(token.c_str(), &end);
  if (token.empty() || end != token.c_str() + token.size()) {
    throw std::invalid_argument(model + ": parameter " + std::to_string(index + 1) +
                                " is not a number: '" + token + "'; expects " +
                                find_camera_model(model).expected_params());
  }
  return value;
}

// "MODEL W H PARAMS..." (tokens already split).
Camera camera_from_tokens(const std::vector<std::string>& tokens, std::size_t first) {
  const std::string& model = tokens[first];
  const auto& found = find_camera_model(model);  // unknown model -> lists the known ones
  if (tokens.size() < first + 3) {
    throw std::invalid_argument(model + ": a camera line is 'MODEL WIDTH HEIGHT PARAMS...' with " +
                                found.expected_params());
  }
  const int64_t width = parse_size(tokens[first + 1], "width", model);
  const int64_t height = parse_size(tokens[first + 2], "height", model);
  std::vector<double> params;
  for (std::size_t i = first + 3; i < tokens.size(); ++i) {
    params.push_back(parse_number(tokens[i], model, i - first - 3));
  }
  return Camera(model, width, height, std::move(params));
}

// A line is "MODEL W H ..." or "ID MODEL W H ...".
bool looks_like_line(const std::vector<std::string>& tokens, std::size_t* model_index) {
  if (!tokens.empty() && is_model_name(tokens[0])) {
    *model_index = 0;
    return true;
  }
  if (tokens.size() >= 2 && is_integer(tokens[0]) && is_model_name(tokens[1])) {
    *model_index = 1;
    return true;
  }
  return false;
}

// The model's own errors (size, parameters) prefixed with `source`, so that a file's errors
// name the file.
template <typename Make>
Camera named(const std::string& source, Make make) {
  try {
    return make();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(source + ": " + e.what());
  }
}

constexpr const char* kExpectedJson =
    "expected {\"model\": NAME, \"width\": W, \"height\": H, \"params\": [...]}, a "
    "camera.json written by predict ({\"camera\": {...}, ...}) or a UniK3D camera "
    "({\"name\": CLASS, \"params\": [...]})";

std::vector<double> json_params(const nlohmann::json& json, const std::string& source) {
  std::vector<double> params;
  for (const auto& value : json["params"]) {
    if (!value.is_number())
      throw std::invalid_argument(source + ": params must be numbers; " + kExpectedJson);
    params.push_back(value.get<double>());
  }
  return params;
}

bool has_integer(const nlohmann::json& json, const char* key) {
  return json.contains(key) && json[key].is_number_integer();
}

// {"model": NAME, "width": W, "height": H, "params": [...]}
Camera camera_from_object(const nlohmann::json& json, const std::string& source) {
  if (!json.is_object() || !json.contains("model") || !json["model"].is_string() ||
      !has_integer(json, "width") || !has_integer(json, "height") || !json.contains("params") ||
      !json["params"].is_array()) {
    throw std::invalid_argument(source + ": " + kExpectedJson);
  }
  std::vector<double> params = json_params(json, source);
  return named(source, [&] {
    return Camera(json["model"].get<std::string>(), json["width"].get<int64_t>(),
                  json["height"].get<int64_t>(), std::move(params));
  });
}

// predict's camera.json (predict/outputs.h): the camera object under "camera", null when
// none was fitted ("fit_error" then says why).
Camera camera_from_prediction_summary(const nlohmann::json& json, const std::string& source) {
  const nlohmann::json& camera = json["camera"];
  if (camera.is_null()) {
    std::string why = "no camera was fitted";
    if (json.contains("fit_error") && json["fit_error"].is_string())
      why += ": " + json["fit_error"].get<std::string>();
    throw std::invalid_argument(source + ": holds no camera (\"camera\": null; " + why +
                                "); pass the camera itself");
  }
  return camera_from_object(camera, source);
}

// {"name": CLASS, "params": [...]} with optional "width" and "height" (unik3d.h).
Camera camera_from_unik3d_object(const nlohmann::json& json, const std::string& source,
                                 std::optional<ImageSize> image_size) {
  if (!json["name"].is_string() || !json.contains("params") || !json["params"].is_array())
    throw std::invalid_argument(source + ": " + kExpectedJson);
  if (has_integer(json, "width") && has_integer(json, "height"))
    image_size = ImageSize{json["width"].get<int64_t>(), json["height"].get<int64_t>()};
  const std::vector<double> params = json_params(json, source);
  return named(source, [&] {
    return camera_from_unik3d(json["name"].get<std::string>(), params, image_size);
  });
}

Camera camera_from_json(const std::string& text, const std::string& source,
                        std::optional<ImageSize> image_size) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(source + ": not valid JSON (" + e.what() + ")");
  }
  if (json.is_object() && !json.contains("model")) {
    if (json.contains("camera")) return camera_from_prediction_summary(json, source);
    if (json.contains("name")) return camera_from_unik3d_object(json, source, image_size);
  }
  return camera_from_object(json, source);
}

// A cameras.txt file: '#' comments, then "ID MODEL W H PARAMS..." lines (or one "MODEL W H
// PARAMS..." line). `id` empty -> the first camera.
Camera camera_from_text_file(const std::string& text, const std::string& path,
                             const std::string& id) {
  std::istringstream in(text);
  std::vector<std::string> ids;
  for (std::string line; std::getline(in, line);) {
    line = trim(line);
    if (line.empty() || line[0] == '#') continue;
    const auto tokens = split_whitespace(line);
    std::size_t model_index = 0;
    if (!looks_like_line(tokens, &model_index)) {
      throw std::invalid_argument(
          path + ": not a camera line (expected 'ID MODEL WIDTH HEIGHT PARAMS...'): '" + line +
          "'");
    }
    const std::string line_id = model_index == 1 ? tokens[0] : "";
    if (id.empty() || line_id == id)
      return named(path, [&] { return camera_from_tokens(tokens, model_index); });
    ids.push_back(line_id);
  }
  if (id.empty()) throw std::invalid_argument(path + ": contains no camera");
  std::string known;
  for (const auto& each : ids) known += " " + each;
  throw std::invalid_argument(path + ": no camera with id " + id + " (ids:" + known + ")");
}

// The shortest of %.15g / %.17g that parses back to exactly `value`.
std::string format_double(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.15g", value);
  if (std::strtod(buffer, nullptr) != value) std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

}  // namespace

Camera parse_camera(const std::string& spec, std::optional<ImageSize> image_size) {
  const std::string text = trim(spec);
  if (text.empty()) {
    throw std::invalid_argument(
        "empty camera spec; expected 'MODEL WIDTH HEIGHT PARAMS...' or a JSON object");
  }
  if (text[0] == '{') return camera_from_json(text, "camera spec", image_size);
  const auto tokens = split_whitespace(text);
  std::size_t model_index = 0;
  if (tokens.size() > 1 && looks_like_line(tokens, &model_index))
    return camera_from_tokens(tokens, model_index);
  if (tokens.size() == 1 && is_model_name(tokens[0])) return camera_from_tokens(tokens, 0);
  throw std::invalid_argument("camera spec '" + text +
                              "' is not a camera line ('MODEL WIDTH HEIGHT PARAMS...') or a JSON "
                              "object");
}

bool is_camera_line(const std::string& spec) {
  const std::string text = trim(spec);
  if (text.empty() || text[0] == '{') return !text.empty();
  const auto tokens = split_whitespace(text);
  std::size_t model_index = 0;
  return (tokens.size() > 1 && looks_like_line(tokens, &model_index)) ||
         (tokens.size() == 1 && is_model_name(tokens[0]));
}

Camera parse_camera_file(const std::string& text, const std::string& source, const std::string& id,
                         std::optional<ImageSize> image_size) {
  if (trim(text).rfind('{', 0) == 0) {
    if (!id.empty())
      throw std::invalid_argument(source + ": a JSON camera file holds one camera; drop '#" + id +
                                  "'");
    return camera_from_json(text, source, image_size);
  }
  if (!id.empty() && !is_integer(id))
    throw std::invalid_argument(source + ": camera id must be an integer, got '" + id + "'");
  return camera_from_text_file(text, source, id);
}

std::string Camera::to_spec() const {
  std::string spec = model_name_ + " " + std::to_string(width_) + " " + std::to_string(height_);
  for (const double value : params_) spec += " " + format_double(value);
  return spec;
}

std::string cameras_txt_line(const Camera& camera, int64_t id) {
  return std::to_string(id) + " " + camera.to_spec();
}

std::string to_cameras_txt(const Camera& camera, int64_t id) {
  return "# Camera list with one line of data per camera:\n"
         "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
         "# Number of cameras: 1\n" +
         cameras_txt_line(camera, id) + "\n";
}

std::string Camera::to_json() const {
  nlohmann::json json = {
      {"model", model_name_}, {"width", width_}, {"height", height_}, {"params", params_}};
  return json.dump();
}

}  // namespace omnipoint::camera
