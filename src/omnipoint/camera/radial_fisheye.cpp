// The purely radial equidistant fisheye models (COLMAP's names and parameter orders):
//   OPENCV_FISHEYE         fx fy cx cy k1 k2 k3 k4   θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)
//   SIMPLE_RADIAL_FISHEYE  f cx cy k                 θ_d = θ (1 + k θ²)
//   RADIAL_FISHEYE         f cx cy k1 k2             θ_d = θ (1 + k1 θ² + k2 θ⁴)
// pixel = f θ_d (x, y) / r + c; see equidistant_fisheye.h for the domain and the inverse.
#include <string>
#include <utility>
#include <vector>

#include "omnipoint/camera/equidistant_fisheye.h"

namespace omnipoint::camera {
namespace {

class RadialFisheyeModel final : public EquidistantFisheyeModel {
 public:
  RadialFisheyeModel(std::string name, std::vector<std::string> param_names,
                     std::vector<int> radial_indices)
      : name_(std::move(name)),
        param_names_(std::move(param_names)),
        radial_indices_(std::move(radial_indices)) {}

  std::string name() const override { return name_; }
  std::vector<std::string> param_names() const override { return param_names_; }
  std::vector<int> radial_indices() const override { return radial_indices_; }

 private:
  std::string name_;
  std::vector<std::string> param_names_;
  std::vector<int> radial_indices_;
};

}  // namespace

const CameraModel& opencv_fisheye_model() {
  static const RadialFisheyeModel model(
      "OPENCV_FISHEYE", {"fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"}, {4, 5, 6, 7});
  return model;
}

const CameraModel& simple_radial_fisheye_model() {
  static const RadialFisheyeModel model("SIMPLE_RADIAL_FISHEYE", {"f", "cx", "cy", "k"}, {3});
  return model;
}

const CameraModel& radial_fisheye_model() {
  static const RadialFisheyeModel model("RADIAL_FISHEYE", {"f", "cx", "cy", "k1", "k2"}, {3, 4});
  return model;
}

}  // namespace omnipoint::camera
