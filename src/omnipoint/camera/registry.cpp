// The table of all camera models. Adding a model: its file defines the accessor; declare it
// below and add it to the table (see camera_model.h).
#include <sstream>
#include <stdexcept>

#include "omnipoint/camera/camera_model.h"

namespace omnipoint::camera {

const CameraModel& simple_pinhole_model();
const CameraModel& pinhole_model();
const CameraModel& simple_radial_model();
const CameraModel& radial_model();
const CameraModel& opencv_model();
const CameraModel& full_opencv_model();
const CameraModel& fov_model();
const CameraModel& equirectangular_model();
const CameraModel& opencv_fisheye_model();
const CameraModel& simple_radial_fisheye_model();
const CameraModel& radial_fisheye_model();
const CameraModel& thin_prism_fisheye_model();
const CameraModel& rad_tan_thin_prism_fisheye_model();
const CameraModel& mei_model();
const CameraModel& ucm_model();
const CameraModel& eucm_model();
const CameraModel& double_sphere_model();

namespace {

const std::vector<const CameraModel*>& all_models() {
  static const std::vector<const CameraModel*> models = {
      &simple_pinhole_model(),
      &pinhole_model(),
      &simple_radial_model(),
      &radial_model(),
      &opencv_model(),
      &full_opencv_model(),
      &fov_model(),
      &equirectangular_model(),
      &opencv_fisheye_model(),
      &simple_radial_fisheye_model(),
      &radial_fisheye_model(),
      &thin_prism_fisheye_model(),
      &rad_tan_thin_prism_fisheye_model(),
      &mei_model(),
      &ucm_model(),
      &eucm_model(),
      &double_sphere_model(),
  };
  return models;
}

}  // namespace

const CameraModel& find_camera_model(const std::string& name) {
  for (const auto* model : all_models()) {
    if (model->name() == name) return *model;
  }
  std::ostringstream text;
  text << "unknown camera model '" << name << "'; known models:";
  for (const auto& known : camera_model_names()) text << " " << known;
  throw std::invalid_argument(text.str());
}

std::vector<std::string> camera_model_names() {
  std::vector<std::string> names;
  for (const auto* model : all_models()) names.push_back(model->name());
  return names;
}

}  // namespace omnipoint::camera
