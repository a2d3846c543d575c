#pragma once
// Writes a COLMAP sparse model the way COLMAP writes it (reconstruction_io_text.cc and
// reconstruction_io_binary.cc): cameras, images and points3D as .txt with COLMAP's header
// comments and 17-digit numbers, or as little-endian .bin. Tracks are derived from the
// images' observations, as COLMAP keeps them.
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/io/colmap.h"

namespace omnipoint::test {

struct ColmapCameraRecord {
  int64_t id;
  std::string model;  // COLMAP's name
  int64_t width, height;
  std::vector<double> params;  // COLMAP's parameters (EQUIRECTANGULAR: w h)
};

struct ColmapScene {
  std::vector<ColmapCameraRecord> cameras;
  std::vector<io::ColmapImage> images;
  std::map<int64_t, io::ColmapPoint> points;
};

// COLMAP's model id of a name (sensor/models.h). Written out here rather than taken from the
// reader's table (io/colmap_binary.cpp): the test files must not inherit a mistake in it.
inline int32_t colmap_model_id(const std::string& model) {
  static const char* const names[] = {"SIMPLE_PINHOLE",
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
  for (int32_t id = 0; id < 18; ++id)
    if (model == names[id]) return id;
  return -1;
}

// (image id, point2D index) of every observation of each point.
inline std::map<int64_t, std::vector<std::array<uint32_t, 2>>> colmap_tracks(
    const ColmapScene& scene) {
  std::map<int64_t, std::vector<std::array<uint32_t, 2>>> tracks;
  for (const auto& image : scene.images)
    for (size_t j = 0; j < image.point3d_ids.size(); ++j)
      if (image.point3d_ids[j] != -1)
        tracks[image.point3d_ids[j]].push_back(
            {static_cast<uint32_t>(image.id), static_cast<uint32_t>(j)});
  return tracks;
}

inline void write_colmap_text(const std::filesystem::path& folder, const ColmapScene& scene) {
  std::filesystem::create_directories(folder);
  const auto open = [&](const char* file) {
    std::ofstream out(folder / file);
    out.precision(17);
    return out;
  };
  std::ofstream cameras = open("cameras.txt");
  cameras << "# Camera list with one line of data per camera:\n"
          << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
          << "# Number of cameras: " << scene.cameras.size() << '\n';
  for (const auto& camera : scene.cameras) {
    cameras << camera.id << ' ' << camera.model << ' ' << camera.width << ' ' << camera.height;
    for (const double param : camera.params) cameras << ' ' << param;
    cameras << '\n';
  }
  size_t observations = 0;
  for (const auto& image : scene.images) observations += image.points2d.size();
  std::ofstream images = open("images.txt");
  images << "# Image list with two lines of data per image:\n"
         << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
         << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
         << "# Number of images: " << scene.images.size() << ", mean observations per image: "
         << (scene.images.empty() ? 0.0 : double(observations) / scene.images.size()) << '\n';
  for (const auto& image : scene.images) {
    images << image.id;
    for (const double q : image.qvec) images << ' ' << q;
    for (const double t : image.tvec) images << ' ' << t;
    images << ' ' << image.camera_id << ' ' << image.name << '\n';
    for (size_t j = 0; j < image.points2d.size(); ++j)
      images << (j ? " " : "") << image.points2d[j][0] << ' ' << image.points2d[j][1] << ' '
             << image.point3d_ids[j];
    images << '\n';
  }
  const auto tracks = colmap_tracks(scene);
  size_t track_entries = 0;
  for (const auto& [id, track] : tracks) track_entries += track.size();
  std::ofstream points = open("points3D.txt");
  points << "# 3D point list with one line of data per point:\n"
         << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
         << "# Number of points: " << scene.points.size() << ", mean track length: "
         << (scene.points.empty() ? 0.0 : double(track_entries) / scene.points.size()) << '\n';
  for (const auto& [id, point] : scene.points) {
    points << id << ' ' << point.xyz[0] << ' ' << point.xyz[1] << ' ' << point.xyz[2] << ' '
           << int(point.rgb[0]) << ' ' << int(point.rgb[1]) << ' ' << int(point.rgb[2]) << ' '
           << point.error << ' ';
    std::ostringstream track_text;
    if (tracks.count(id))
      for (const auto& [image, index] : tracks.at(id)) track_text << image << ' ' << index << ' ';
    std::string track_line = track_text.str();
    points << track_line.substr(0, track_line.size() - 1) << '\n';
  }
}

template <typename T>
void put(std::string& bytes, T value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

inline std::string colmap_cameras_binary(const ColmapScene& scene) {
  std::string bytes;
  put<uint64_t>(bytes, scene.cameras.size());
  for (const auto& camera : scene.cameras) {
    put<uint32_t>(bytes, static_cast<uint32_t>(camera.id));
    put<int32_t>(bytes, colmap_model_id(camera.model));
    put<uint64_t>(bytes, camera.width);
    put<uint64_t>(bytes, camera.height);
    for (const double param : camera.params) put<double>(bytes, param);
  }
  return bytes;
}

inline std::string colmap_images_binary(const ColmapScene& scene) {
  std::string bytes;
  put<uint64_t>(bytes, scene.images.size());
  for (const auto& image : scene.images) {
    put<uint32_t>(bytes, static_cast<uint32_t>(image.id));
    for (const double q : image.qvec) put<double>(bytes, q);
    for (const double t : image.tvec) put<double>(bytes, t);
    put<uint32_t>(bytes, static_cast<uint32_t>(image.camera_id));
    bytes += image.name;
    bytes += '\0';
    put<uint64_t>(bytes, image.points2d.size());
    for (size_t j = 0; j < image.points2d.size(); ++j) {
      put<double>(bytes, image.points2d[j][0]);
      put<double>(bytes, image.points2d[j][1]);
      put<uint64_t>(bytes, static_cast<uint64_t>(image.point3d_ids[j]));  // -1 -> 2^64 - 1
    }
  }
  return bytes;
}

inline std::string colmap_points_binary(const ColmapScene& scene) {
  const auto tracks = colmap_tracks(scene);
  std::string bytes;
  put<uint64_t>(bytes, scene.points.size());
  for (const auto& [id, point] : scene.points) {
    put<uint64_t>(bytes, id);
    for (const double x : point.xyz) put<double>(bytes, x);
    for (const uint8_t channel : point.rgb) put<uint8_t>(bytes, channel);
    put<double>(bytes, point.error);
    const auto track = tracks.count(id) ? tracks.at(id) : std::vector<std::array<uint32_t, 2>>{};
    put<uint64_t>(bytes, track.size());
    for (const auto& [image, index] : track) {
      put<uint32_t>(bytes, image);
      put<uint32_t>(bytes, index);
    }
  }
  return bytes;
}

inline void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

inline void write_colmap_binary(const std::filesystem::path& folder, const ColmapScene& scene) {
  std::filesystem::create_directories(folder);
  write_bytes(folder / "cameras.bin", colmap_cameras_binary(scene));
  write_bytes(folder / "images.bin", colmap_images_binary(scene));
  write_bytes(folder / "points3D.bin", colmap_points_binary(scene));
}

}  // namespace omnipoint::test
