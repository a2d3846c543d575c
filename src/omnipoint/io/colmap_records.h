#pragma once
// What the text and the binary COLMAP readers (colmap_text.cpp, colmap_binary.cpp) share: the
// error wording, COLMAP's camera models as ours, and the checks every record passes whichever
// format it came in.
#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "omnipoint/io/colmap.h"

namespace omnipoint::io::colmap_records {

// Throws std::invalid_argument "COLMAP <name>: <what>"; `name` is the file.
[[noreturn]] void fail(const std::string& name, const std::string& what);

// COLMAP's EQUIRECTANGULAR carries the panorama's size as its two parameters.
constexpr std::size_t kEquirectangularParams = 2;

// COLMAP models with no OmniPoint counterpart are an error naming the model; `where` names the
// camera.
void check_supported(const std::string& model, const std::string& name, const std::string& where);

// A COLMAP camera as ours; `where` names the camera in errors.
camera::Camera colmap_camera(const std::string& model, int64_t width, int64_t height,
                             std::vector<double> params, const std::string& name,
                             const std::string& where);

// Each record after its checks: finite values, a unit quaternion (normalised here; zero is an
// error), an id that has not appeared before (`ids` holds the image ids so far).
void add_camera(std::map<int64_t, camera::Camera>& cameras, int64_t id, camera::Camera camera,
                const std::string& name);
void add_image(std::vector<ColmapImage>& images, std::set<int64_t>& ids, ColmapImage image,
               const std::string& name);
void add_point(std::map<int64_t, ColmapPoint>& points, int64_t id, const ColmapPoint& point,
               const std::string& name);

}  // namespace omnipoint::io::colmap_records
