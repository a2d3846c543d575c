#include "cli/view_server.h"

#include <ATen/ATen.h>
#include <httplib.h>
#include <spawn.h>
#include <sys/socket.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "cli/bundled.h"
#include "omnipoint/camera/camera_info.h"
#include "omnipoint/geometry/colormap.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/glb.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/io/staged_folder.h"

extern char** environ;

namespace omnipoint::cli {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ordered_json = nlohmann::ordered_json;

std::string slurp(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error(path.string() + ": cannot be read");
  std::ostringstream bytes;
  bytes << file.rdbuf();
  return bytes.str();
}

bool starts_with(const fs::path& path, const fs::path& prefix) {
  return std::mismatch(prefix.begin(), prefix.end(), path.begin(), path.end()).first ==
         prefix.end();
}

struct Resolved {
  int status;     // 200, 403 or 404
  fs::path path;  // canonical, when 200
};

// `relative`, a percent-decoded URL path below `root` (canonical), resolved with its symlinks:
// 200 when it names a `type` inside root; 403 for a `..` component or a path that leaves root;
// 404 when it is missing or of another type.
Resolved resolve_inside(const fs::path& root, const std::string& relative, fs::file_type type) {
  const fs::path path(relative);
  if (path.is_absolute()) return {403, {}};
  for (const fs::path& part : path)
    if (part == "..") return {403, {}};
  std::error_code error;
  const fs::path real = fs::canonical(root / path, error);
  if (error) return {404, {}};
  if (!starts_with(real, root)) return {403, {}};
  if (fs::status(real, error).type() != type) return {404, {}};
  return {200, real};
}

std::string content_type(const fs::path& file) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".glb", "model/gltf-binary"},
      {".txt", "text/plain; charset=utf-8"}};
  const auto known = types.find(file.extension().string());
  return known == types.end() ? "application/octet-stream" : known->second;
}

void send_status(httplib::Response& response, int status) {
  static const std::map<int, std::string> reasons = {{400, "no name given"},
                                                     {403, "outside the served folder"},
                                                     {404, "not found"},
                                                     {405, "read-only: GET and HEAD only"}};
  response.status = status;
  response.set_content(std::to_string(status) + " " + reasons.at(status) + "\n",
                       "text/plain; charset=utf-8");
}

void send_file(httplib::Response& response, const Resolved& file) {
  if (file.status != 200) return send_status(response, file.status);
  response.set_content(slurp(file.path), content_type(file.path));
}

// camera.json of a prediction folder, null when it is unreadable or not JSON.
json read_record(const fs::path& folder) {
  std::ifstream file(folder / "camera.json");
  if (!file) return nullptr;
  json record = json::parse(file, nullptr, /*allow_exceptions=*/false);
  return record.is_discarded() ? json() : record;
}

// The number of points of the folder's cloud as camera.json records it (the valid pixels).
std::optional<int64_t> recorded_points(const json& record) {
  if (record.is_object() && record.contains("valid_pixels") &&
      record["valid_pixels"].is_number_integer())
    return record["valid_pixels"].get<int64_t>();
  return std::nullopt;
}

// Unit rays through the image border, clockwise from the top-left corner, for drawing the
// camera's frustum; null when some are invalid or more than ~84 degrees off the axis (z < 0.1),
// where a frustum says little (wide lenses, panoramas: the page draws centre and axes then).
json frustum_rays(const camera::Camera& camera) {
  constexpr int kStepsPerSide = 8;
  const double width = static_cast<double>(camera.width()),
               height = static_cast<double>(camera.height());
  std::vector<double> pixels;
  for (int step = 0; step < kStepsPerSide; ++step) {
    const double t = static_cast<double>(step) / kStepsPerSide;
    pixels.insert(pixels.end(),
                  {t * width, 0, width, t * height, (1 - t) * width, height, 0, (1 - t) * height});
  }
  // The loop above interleaves the four sides; put each side's steps together.
  const at::Tensor interleaved = at::tensor(pixels, at::kDouble).reshape({kStepsPerSide, 4, 2});
  const camera::Rays rays = camera.unproject(interleaved.transpose(0, 1).reshape({-1, 2}));
  if (!rays.valid.all().item<bool>() || rays.rays.select(1, 2).min().item<double>() < 0.1)
    return nullptr;
  json out = json::array();
  for (int64_t i = 0; i < rays.rays.size(0); ++i)
    out.push_back({rays.rays[i][0].item<double>(), rays.rays[i][1].item<double>(),
                   rays.rays[i][2].item<double>()});
  return out;
}

const char* class_name(camera::CameraClass kind) {
  switch (kind) {
    case camera::CameraClass::kPerspective:
      return "perspective";
    case camera::CameraClass::kWide:
      return "wide";
    case camera::CameraClass::kPanorama:
      return "panorama";
  }
  return "unknown";
}

json describe_prediction(const std::string& name, const fs::path& folder) {
  json files = json::array();
  for (const fs::directory_entry& entry : fs::directory_iterator(folder))
    if (entry.is_regular_file() && entry.path().filename().string().front() != '.')
      files.push_back(entry.path().filename().string());
  std::sort(files.begin(), files.end());
  json out = {
      {"name", name}, {"kind", "prediction"}, {"files", files}, {"record", read_record(folder)}};
  out["camera_class"] = nullptr;
  try {
    const camera::Camera camera = io::read_camera((folder / "camera.json").string());
    out["camera_class"] = class_name(camera::camera_class(camera));
    out["frustum_rays"] = frustum_rays(camera);
  } catch (const std::exception& e) {
    out["camera_error"] = e.what();  // no camera fitted, or an unreadable camera.json
  }
  return out;
}

// A rig frame written by `predict --rig` (predict/rig_predict_job.h): rig.json, fused.ply
// (and fused.glb) in the body frame, and one prediction folder per camera.
bool is_rig_frame(const fs::path& folder) {
  return fs::is_regular_file(folder / "rig.json");
}

// 3 rows of 4 finite numbers (or 4 rows), as rig.json writes a camera's body_from_camera.
bool is_pose_rows(const ordered_json& rows) {
  if (!rows.is_array() || (rows.size() != 3 && rows.size() != 4)) return false;
  for (const ordered_json& row : rows) {
    if (!row.is_array() || row.size() != 4) return false;
    for (const ordered_json& value : row)
      if (!value.is_number() || !std::isfinite(value.get<double>())) return false;
  }
  return true;
}

// FOLDER/rig.json (`shown`: FOLDER as the user named it), checked for what the page draws: its
// "cameras" map each camera's name to its body_from_camera, scale and scale_source; and the
// frame's cloud, fused.ply or fused.glb, must be there. A problem -> std::invalid_argument naming
// the file and the field.
ordered_json read_rig_frame(const fs::path& folder, const std::string& shown) {
  const std::string file = shown + "/rig.json";
  const auto bad = [&file](const std::string& problem) {
    return std::invalid_argument("view: " + file + ": " + problem);
  };
  std::ifstream in(folder / "rig.json");
  if (!in) throw std::runtime_error("view: " + file + ": cannot be read");
  ordered_json report;
  try {
    report = ordered_json::parse(in);
  } catch (const ordered_json::parse_error& e) {
    throw bad(std::string("not JSON (") + e.what() + ")");
  }
  if (!report.is_object() || !report.contains("cameras") || !report["cameras"].is_object() ||
      report["cameras"].empty())
    throw bad(
        "cameras: expected an object of the frame's cameras by name, as predict --rig "
        "writes");
  for (const auto& [name, camera] : report["cameras"].items()) {
    const std::string field = "cameras." + name;
    if (!camera.is_object()) throw bad(field + ": expected an object");
    if (!camera.contains("body_from_camera") || !is_pose_rows(camera["body_from_camera"]))
      throw bad(field + ".body_from_camera: expected 3 rows of 4 numbers");
    if (!camera.contains("scale") || !camera["scale"].is_number())
      throw bad(field + ".scale: expected a number");
    if (!camera.contains("scale_source") || !camera["scale_source"].is_string())
      throw bad(field + ".scale_source: expected a string");
  }
  if (!fs::is_regular_file(folder / "fused.ply") && !fs::is_regular_file(folder / "fused.glb"))
    throw std::invalid_argument("view: " + shown +
                                ": no fused.ply (the frame's cloud that predict --rig writes)");
  return report;
}

std::optional<int64_t> fused_points(const ordered_json& report) {
  if (report.contains("fused_points") && report["fused_points"].is_number_integer())
    return report["fused_points"].get<int64_t>();
  return std::nullopt;
}

// The body frame's up direction: the mean of the cameras' up directions (-y of a camera frame,
// whose y points down), as a rig's cameras are mounted about level; the first camera's where
// they cancel out.
ordered_json body_up(const ordered_json& cameras) {
  double up[3] = {0, 0, 0};
  const auto add = [&up](const ordered_json& rows) {
    for (int i = 0; i < 3; ++i) up[i] -= rows[i][1].get<double>();
  };
  for (const auto& camera : cameras) add(camera["body_from_camera"]);
  if (std::hypot(up[0], up[1], up[2]) < 1e-6) {
    up[0] = up[1] = up[2] = 0;
    add(cameras.front()["body_from_camera"]);
  }
  const double norm = std::hypot(up[0], up[1], up[2]);
  return {up[0] / norm, up[1] / norm, up[2] / norm};
}

// A rig frame for the page: rig.json as it is, the body frame's up, and each camera as rig.json
// reports it with its name, its folder (by name below the served folder), its class and the
// rays of its frustum (describe_prediction), from its folder's camera.json.
ordered_json describe_rig_frame(const fs::path& root, const std::string& name,
                                const fs::path& folder) {
  const ordered_json report = read_rig_frame(folder, name);
  ordered_json cameras = ordered_json::array();
  for (const auto& [camera_name, entry] : report["cameras"].items()) {
    ordered_json camera = {{"name", camera_name}};
    camera.update(entry);
    const std::string camera_folder = name == "." ? camera_name : name + "/" + camera_name;
    const Resolved resolved = resolve_inside(root, camera_folder, fs::file_type::directory);
    camera["folder"] = resolved.status == 200 ? ordered_json(camera_folder) : ordered_json();
    camera["has_image"] =
        resolved.status == 200 && fs::is_regular_file(resolved.path / "image.png");
    camera["camera_class"] = nullptr;
    camera["frustum_rays"] = nullptr;
    try {
      if (resolved.status != 200) throw std::runtime_error("no folder " + camera_folder);
      const camera::Camera model = io::read_camera((resolved.path / "camera.json").string());
      camera["camera_class"] = class_name(camera::camera_class(model));
      camera["frustum_rays"] = ordered_json(frustum_rays(model));
    } catch (const std::exception& e) {
      camera["camera_error"] = e.what();  // the page draws its centre and axes
    }
    cameras.push_back(camera);
  }
  ordered_json files = ordered_json::array();
  for (const std::string file : {"fused.ply", "fused.glb", "rig.json"})
    if (fs::is_regular_file(folder / file)) files.push_back(file);
  return {{"name", name},
          {"kind", "rig"},
          {"files", files},
          {"record", report},
          {"up", body_up(report["cameras"])},
          {"cameras", cameras}};
}

// A 16-bit map (depth.png, distance.png: a browser shows only their high byte) as an 8-bit PNG
// coloured by inverse value like depth_vis.png, with Viridis to tell the two apart.
std::string colourised_png(const fs::path& map) {
  const at::Tensor values = io::read_image_values(map.string());
  if (values.dim() != 2) throw std::invalid_argument(map.string() + ": not a one-channel map");
  // io writes PNGs to files only: through a temporary one outside the served folder.
  static std::atomic<int> counter{0};
  const fs::path temporary =
      fs::temp_directory_path() /
      ("omnipoint_view_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + ".png");
  io::write_image_png(temporary.string(),
                      geometry::colorize_depth(values, values > 0, geometry::Colormap::Viridis));
  std::string png = slurp(temporary);
  fs::remove(temporary);
  return png;
}

struct Cloud {
  std::string glb;
  std::optional<int64_t> total;
  int64_t shown = 0;
};

// STEM.glb when it holds at most `max_points` points by `recorded` (or there is no STEM.ply to
// take fewer from), else every (total / max_points)-th point of STEM.ply, evenly spread over
// the image rows. Both files are resolved inside `root` like any other.
std::optional<Cloud> load_cloud(const fs::path& root, const std::string& name,
                                const std::string& stem, std::optional<int64_t> recorded,
                                int64_t max_points) {
  const Resolved glb = resolve_inside(root, name + "/" + stem + ".glb", fs::file_type::regular);
  const Resolved ply = resolve_inside(root, name + "/" + stem + ".ply", fs::file_type::regular);
  if (glb.status == 200 && (ply.status != 200 || (recorded && *recorded <= max_points)))
    return Cloud{slurp(glb.path), recorded, recorded.value_or(-1)};
  if (ply.status != 200) return std::nullopt;
  const io::PlyPoints cloud = io::read_ply(ply.path.string());
  const int64_t total = cloud.points.size(0), shown = std::min(total, max_points);
  const at::Tensor kept = at::div(at::arange(shown, at::kLong) * total, shown, "floor");
  return Cloud{io::encode_glb_points(
                   cloud.points.index_select(0, kept),
                   cloud.colors.defined() ? cloud.colors.index_select(0, kept) : at::Tensor()),
               total, shown};
}

// Whether `folder` is shown: a prediction folder (camera.json) or a rig frame (rig.json).
bool is_shown(const fs::path& folder) {
  return fs::is_regular_file(folder / "camera.json") || is_rig_frame(folder);
}

// Ready-made prediction folders and rig frames below `root`: staging folders (predict's
// unfinished ones, io::StagedFolder), other hidden ones and symlinked ones are not entered.
std::vector<std::string> find_folders(const fs::path& root) {
  std::vector<std::string> names;
  if (is_shown(root)) names.emplace_back(".");
  for (auto entry =
           fs::recursive_directory_iterator(root, fs::directory_options::skip_permission_denied);
       entry != fs::recursive_directory_iterator(); ++entry) {
    if (!entry->is_directory() || entry->is_symlink()) continue;
    if (io::is_staging_folder(entry->path()) || entry->path().filename().string().front() == '.') {
      entry.disable_recursion_pending();
      continue;
    }
    if (is_shown(entry->path()))
      names.push_back(fs::relative(entry->path(), root).generic_string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool is_loopback(const std::string& host) {
  return host == "127.0.0.1" || host == "localhost" || host == "::1";
}

void open_in_browser(const std::string& url) {
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((display != nullptr && *display != '\0') || (wayland != nullptr && *wayland != '\0')) {
    std::string program = "xdg-open", argument = url;
    char* arguments[] = {program.data(), argument.data(), nullptr};
    pid_t child = 0;
    if (posix_spawnp(&child, "xdg-open", nullptr, nullptr, arguments, environ) == 0) return;
  }
  std::cout << "omnipoint view: no browser to open here (no display or no xdg-open): open " << url
            << " in one" << std::endl;
}

// The server's manners: no caching, an exclusive port, GET and HEAD only, an exception as a
// 500 with its message.
void configure(httplib::Server& server) {
  // Predictions are rewritten in place: the browser asks again each time.
  server.set_default_headers({{"Cache-Control", "no-cache"}});
  // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, with which a second server would
  // share a port that is in use instead of failing.
  server.set_socket_options([](socket_t socket) {
    const int on = 1;
    ::setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &on, sizeof(on));
  });
  // Read-only: GET (and HEAD, which httplib answers from the GET handlers) and nothing else.
  server.set_pre_routing_handler([](const httplib::Request& request, httplib::Response& response) {
    if (request.method == "GET" || request.method == "HEAD")
      return httplib::Server::HandlerResponse::Unhandled;
    response.set_header("Allow", "GET, HEAD");
    send_status(response, 405);
    return httplib::Server::HandlerResponse::Handled;
  });
  server.set_exception_handler(
      [](const httplib::Request&, httplib::Response& response, const std::exception_ptr& error) {
        response.status = 500;
        try {
          std::rethrow_exception(error);
        } catch (const std::exception& e) {
          response.set_content(std::string(e.what()) + "\n", "text/plain; charset=utf-8");
        } catch (...) {
          response.set_content("an unknown exception\n", "text/plain; charset=utf-8");
        }
      });
}

// The page and three.js's files (view_server.h: the routes).
void route_page(httplib::Server& server, const fs::path& page, const fs::path& three) {
  server.Get("/", [page](const httplib::Request&, httplib::Response& response) {
    send_file(response, resolve_inside(page, "index.html", fs::file_type::regular));
  });
  server.Get(R"(/(view\.js|view\.css))", [page](const httplib::Request& request,
                                                httplib::Response& response) {
    send_file(response, resolve_inside(page, request.matches[1].str(), fs::file_type::regular));
  });
  server.Get("/three/(.+)", [three](const httplib::Request& request, httplib::Response& response) {
    send_file(response, resolve_inside(three, request.matches[1].str(), fs::file_type::regular));
  });
}

// The predictions under `root` (view_server.h: the routes).
void route_predictions(httplib::Server& server, const fs::path& root, const ViewOptions& options) {
  server.Get("/files/(.+)", [root](const httplib::Request& request, httplib::Response& response) {
    send_file(response, resolve_inside(root, request.matches[1].str(), fs::file_type::regular));
  });
  server.Get(
      "/colourised/(.+)", [root](const httplib::Request& request, httplib::Response& response) {
        const Resolved map = resolve_inside(root, request.matches[1].str(), fs::file_type::regular);
        if (map.status != 200) return send_status(response, map.status);
        response.set_content(colourised_png(map.path), "image/png");
      });
  server.Get("/api/predictions", [root, options](const httplib::Request&,
                                                 httplib::Response& response) {
    json list = json::array();
    for (const std::string& name : find_folders(root)) {
      const bool rig = is_rig_frame(root / name);
      std::optional<int64_t> points;
      try {
        points = rig ? fused_points(read_rig_frame(root / name, name))
                     : recorded_points(read_record(root / name));
      } catch (const std::exception&) {
        points.reset();  // a rig frame broken since the start: listed, its page gets the error
      }
      list.push_back({{"name", name},
                      {"kind", rig ? "rig" : "prediction"},
                      {"points", points ? json(*points) : json()}});
    }
    const json out = {
        {"root", options.dir.string()}, {"max_points", options.max_points}, {"predictions", list}};
    response.set_content(out.dump(), "application/json");
  });
  // A prediction by name (a query parameter: a path would lose the "." of DIR itself).
  const auto named_folder = [root](const httplib::Request& request, httplib::Response& response) {
    if (!request.has_param("name")) {
      send_status(response, 400);
      return Resolved{400, {}};
    }
    Resolved folder =
        resolve_inside(root, request.get_param_value("name"), fs::file_type::directory);
    if (folder.status != 200) send_status(response, folder.status);
    return folder;
  };
  server.Get("/api/prediction",
             [root, named_folder](const httplib::Request& request, httplib::Response& response) {
               const Resolved folder = named_folder(request, response);
               if (folder.status != 200) return;
               const std::string name = request.get_param_value("name");
               response.set_content(is_rig_frame(folder.path)
                                        ? describe_rig_frame(root, name, folder.path).dump()
                                        : describe_prediction(name, folder.path).dump(),
                                    "application/json");
             });
  server.Get("/cloud", [root, options, named_folder](const httplib::Request& request,
                                                     httplib::Response& response) {
    const Resolved folder = named_folder(request, response);
    if (folder.status != 200) return;
    const std::string name = request.get_param_value("name");
    const bool rig = is_rig_frame(folder.path);
    const std::optional<Cloud> cloud =
        rig ? load_cloud(root, name, "fused", fused_points(read_rig_frame(folder.path, name)),
                         options.max_points)
            : load_cloud(root, name, "points", recorded_points(read_record(folder.path)),
                         options.max_points);
    if (!cloud) return send_status(response, 404);
    if (cloud->total)
      response.set_header("X-Omnipoint-Points-Total", std::to_string(*cloud->total));
    if (cloud->shown >= 0)
      response.set_header("X-Omnipoint-Points-Shown", std::to_string(cloud->shown));
    response.set_content(cloud->glb, "model/gltf-binary");
  });
}

// Binds options.host:options.port (0: any free port); returns the port.
int bind_port(httplib::Server& server, const ViewOptions& options) {
  int port = options.port;
  errno = 0;
  if (port == 0) {
    port = server.bind_to_any_port(options.host);
  } else if (!server.bind_to_port(options.host, port)) {
    port = -1;
  }
  if (port < 0) {
    const int reason = errno;
    throw std::runtime_error("view: cannot listen on " + options.host + ":" +
                             std::to_string(options.port) + ": " +
                             (reason == EADDRINUSE ? std::string("the port is in use")
                              : reason != 0        ? std::strerror(reason)
                                                   : std::string("bind failed")) +
                             " (--port N picks another, --port 0 any free one)");
  }
  return port;
}

}  // namespace

bool viewer_available() {
  return true;
}

void serve_predictions(const ViewOptions& options) {
  if (!fs::is_directory(options.dir))
    throw std::invalid_argument("view: " + options.dir.string() + ": no such folder");
  const fs::path root = fs::canonical(options.dir);
  // Rig frames are checked now: a bad one is one error line before serving anything.
  std::size_t predictions = 0, rig_frames = 0;
  for (const std::string& name : find_folders(root)) {
    if (!is_rig_frame(root / name)) {
      ++predictions;
      continue;
    }
    read_rig_frame(root / name, name == "." ? options.dir.string() : (options.dir / name).string());
    ++rig_frames;
  }
  if (predictions + rig_frames == 0)
    throw std::invalid_argument("view: " + options.dir.string() +
                                " holds no prediction folder (one with the camera.json that "
                                "`omnipoint predict` writes) and no rig frame (the rig.json of "
                                "`predict --rig`)");
  const std::string rebuild = ": reinstall omnipoint, or rebuild it (npm ci installs three.js)";
  const fs::path page = fs::canonical(
      find_bundled(OMNIPOINT_INSTALLED_VIEW, OMNIPOINT_SOURCE_VIEW, "the viewer's page", rebuild));
  const fs::path three = fs::canonical(
      find_bundled(OMNIPOINT_INSTALLED_VIEW "/three", OMNIPOINT_BUILT_THREE, "three.js", rebuild));

  httplib::Server server;
  configure(server);
  route_page(server, page, three);
  route_predictions(server, root, options);
  const int port = bind_port(server, options);
  if (!is_loopback(options.host))
    std::cerr << "omnipoint: warning: view: listening on " << options.host
              << ", not only this machine: whoever reaches it can read every file under "
              << root.string() << "\n";
  const std::string host =
      options.host.find(':') == std::string::npos ? options.host : "[" + options.host + "]";
  const std::string url = "http://" + host + ":" + std::to_string(port) + "/";
  std::cout << "omnipoint view: serving "
            << (rig_frames > 0 ? std::to_string(rig_frames) + " rig frame(s) and " : "")
            << predictions << " prediction(s) of " << options.dir.string() << " at " << url
            << " (Ctrl-C stops)" << std::endl;
  if (options.open_browser) open_in_browser(url);
  if (!server.listen_after_bind())
    throw std::runtime_error("view: the server on " + url + " stopped on an error");
}

}  // namespace omnipoint::cli
