#include "omnipoint/io/jpeg.h"

#include <ATen/ATen.h>

#include <stdexcept>
#include <string>
#include <vector>

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#endif

namespace omnipoint::io {

at::Tensor jpeg_round_trip(const at::Tensor& image, int quality) {
  if (image.dim() != 3 || image.size(2) != 3 || !at::isFloatingType(image.scalar_type()))
    throw std::invalid_argument("jpeg_round_trip: expected a floating (H, W, 3) image");
  if (quality < 1 || quality > 100)
    throw std::invalid_argument("jpeg_round_trip: quality " + std::to_string(quality) +
                                " not in 1..100");
#ifdef OMNIPOINT_WITH_OPENCV
  // OpenCV stores BGR: flip the channels on the way in and out.
  const auto bytes = at::round(image.detach().to(at::kCPU, at::kFloat).clamp(0, 1) * 255)
                         .to(at::kByte)
                         .flip({2})
                         .contiguous();
  const cv::Mat mat(static_cast<int>(bytes.size(0)), static_cast<int>(bytes.size(1)), CV_8UC3,
                    bytes.data_ptr());
  std::vector<uchar> buffer;
  cv::imencode(".jpg", mat, buffer, {cv::IMWRITE_JPEG_QUALITY, quality});
  const cv::Mat decoded = cv::imdecode(buffer, cv::IMREAD_COLOR);
  if (decoded.empty() || decoded.rows != mat.rows || decoded.cols != mat.cols)
    throw std::runtime_error("jpeg_round_trip: OpenCV failed to encode/decode the image");
  const auto out = at::from_blob(decoded.data, {decoded.rows, decoded.cols, 3}, at::kByte)
                       .flip({2})
                       .to(at::kFloat) /
                   255.0;
  return out.to(image.device());
#else
  throw std::runtime_error("jpeg_round_trip: this build has no image I/O (built without OpenCV)");
#endif
}

}  // namespace omnipoint::io
