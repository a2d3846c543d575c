#pragma once
// Summaries of a camera for people: its fields of view and how much of its image is valid.
#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {

// Fields of view in degrees, measured as the angle swept by the rays along the image's middle
// row (horizontal), middle column (vertical) and main diagonal, counting only the stretches
// where rays are valid. This holds for every model: 360 for a full panorama, beyond 180 for
// wide fisheyes, and the crop's extent for a cropped panorama.
struct FieldOfView {
  double horizontal_deg;
  double vertical_deg;
  double diagonal_deg;
};
FieldOfView field_of_view(const Camera& camera);

// The kind of lens a camera model stands for (benchmark splits, which items P2A/A2P take):
// EQUIRECTANGULAR -> kPanorama; the fisheye, unified and FOV models (OPENCV_FISHEYE,
// *_FISHEYE, FOV, MEI, UCM, EUCM, DOUBLE_SPHERE) -> kWide; pinhole and OpenCV-style
// models -> kPerspective. By model, not by the parameters' actual field of view.
enum class CameraClass { kPerspective, kWide, kPanorama };
CameraClass camera_class(const Camera& camera);

// Share of the pixels whose centre unprojects to a valid ray.
double valid_fraction(const Camera& camera);

}  // namespace omnipoint::camera
