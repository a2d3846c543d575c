#include "omnipoint/io/image.h"

#include <ATen/ATen.h>

#include <set>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/file_name.h"

#ifdef OMNIPOINT_WITH_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <ostream>

#include "omnipoint/io/atomic_file.h"
#endif

namespace omnipoint::io {

bool has_image_extension(const std::string& path) {
  static const std::set<std::string> extensions = {
      ".png", ".jpg", ".jpeg", ".jpe", ".webp", ".tif", ".tiff", ".bmp", ".dib",
      ".jp2", ".pbm", ".pgm",  ".ppm", ".pnm",  ".pxm", ".sr",   ".ras"};
  return extensions.count(lower_extension(path)) > 0;
}

#ifdef OMNIPOINT_WITH_OPENCV
namespace {

struct Decoded {
  cv::Mat values;  // float32, the stored values, channels in RGB(A) order
  int depth;       // the stored depth: CV_8U, CV_16U or CV_32F
};

Decoded decode(const std::string& path) {
  const std::string bytes = read_file(path);
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": cannot decode the image: " + e.what());
  }
  if (decoded.empty()) {
    throw std::runtime_error(path +
                             ": cannot decode the image (corrupt file or unsupported format)");
  }
  const int depth = decoded.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F) {
    throw std::runtime_error(path +
                             ": unsupported pixel depth (expected 8-bit, 16-bit or 32-bit float)");
  }
  const int channels = decoded.channels();
  if (channels != 1 && channels != 3 && channels != 4) {
    throw std::runtime_error(path + ": unsupported channel count " + std::to_string(channels));
  }
  cv::Mat values;
  decoded.convertTo(values, CV_MAKETYPE(CV_32F, channels));
  if (channels == 3) cv::cvtColor(values, values, cv::COLOR_BGR2RGB);
  if (channels == 4) cv::cvtColor(values, values, cv::COLOR_BGRA2RGBA);
  return {values, depth};
}

at::Tensor to_tensor(const cv::Mat& m) {
  const cv::Mat c = m.isContinuous() ? m : m.clone();
  std::vector<int64_t> shape = {c.rows, c.cols};
  if (c.channels() > 1) shape.push_back(c.channels());
  return at::from_blob(c.data, shape, at::kFloat).clone();
}

}  // namespace

bool image_io_available() {
  return true;
}

at::Tensor read_image(const std::string& path) {
  const Decoded decoded = decode(path);
  if (decoded.depth == CV_32F) {
    throw std::runtime_error(
        path + ": a floating-point image is not a colour image (expected 8 or 16 bits)");
  }
  const double scale = decoded.depth == CV_16U ? 1.0 / 65535.0 : 1.0 / 255.0;
  at::Tensor t = to_tensor(decoded.values) * scale;
  if (t.dim() == 2) return t.unsqueeze(-1).expand({t.size(0), t.size(1), 3}).contiguous();
  return t.narrow(-1, 0, 3).contiguous();
}

at::Tensor read_image_values(const std::string& path) {
  return to_tensor(decode(path).values);
}

void write_image_png(const std::string& path, const at::Tensor& image, int float_bits) {
  const auto bad = [&](const std::string& what) {
    throw std::invalid_argument(path + ": cannot write the PNG: " + what);
  };
  if (!image.defined() || (image.dim() != 2 && image.dim() != 3) ||
      (image.dim() == 3 && image.size(2) != 3 && image.size(2) != 4 && image.size(2) != 1)) {
    bad("expected a tensor of shape (H, W), (H, W, 3) or (H, W, 4)");
  }
  if (image.numel() == 0) bad("the image is empty");
  if (float_bits != 8 && float_bits != 16) bad("float_bits must be 8 or 16");
  at::Tensor t = image.to(at::kCPU);
  bool sixteen = false;
  if (t.scalar_type() == at::kBool) {
    t = t.to(at::kByte) * 255;
  } else if (t.scalar_type() == at::kByte) {
  } else if (t.scalar_type() == at::kShort || t.scalar_type() == at::kInt ||
             t.scalar_type() == at::kLong) {
    if (t.min().item<int64_t>() < 0 || t.max().item<int64_t>() > 65535)
      bad("16-bit values must lie in [0, 65535]");
    t = t.to(at::kInt);
    sixteen = true;
  } else if (at::isFloatingType(t.scalar_type())) {
    if (at::isnan(t).any().item<bool>()) bad("the image contains NaN");
    const double top = float_bits == 16 ? 65535.0 : 255.0;
    t = (t.to(at::kDouble).clamp(0, 1) * top).round().to(at::kInt);
    sixteen = float_bits == 16;
    if (!sixteen) t = t.to(at::kByte);
  } else {
    bad("unsupported dtype (expected bool, uint8, int16/32/64 or floating)");
  }
  t = t.contiguous();
  const int channels = t.dim() == 3 ? static_cast<int>(t.size(2)) : 1;
  const int rows = static_cast<int>(t.size(0)), cols = static_cast<int>(t.size(1));
  cv::Mat m;
  if (sixteen) {
    cv::Mat(rows, cols, CV_MAKETYPE(CV_32S, channels), t.data_ptr())
        .convertTo(m, CV_MAKETYPE(CV_16U, channels));
  } else {
    m = cv::Mat(rows, cols, CV_MAKETYPE(CV_8U, channels), t.data_ptr()).clone();
  }
  if (channels == 3) cv::cvtColor(m, m, cv::COLOR_RGB2BGR);
  if (channels == 4) cv::cvtColor(m, m, cv::COLOR_RGBA2BGRA);
  std::vector<uchar> encoded;
  if (!cv::imencode(".png", m, encoded)) throw std::runtime_error(path + ": PNG encoding failed");
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(encoded.data()),
              static_cast<std::streamsize>(encoded.size()));
  });
}

#else  // built without OpenCV

namespace {
[[noreturn]] void unavailable(const std::string& path) {
  throw std::runtime_error(path +
                           ": omnipoint was built without image I/O (OpenCV); "
                           "reconfigure with -DOMNIPOINT_WITH_OPENCV=ON");
}
}  // namespace

bool image_io_available() {
  return false;
}
at::Tensor read_image(const std::string& path) {
  unavailable(path);
}
at::Tensor read_image_values(const std::string& path) {
  unavailable(path);
}
void write_image_png(const std::string& path, const at::Tensor&, int) {
  unavailable(path);
}

#endif

}  // namespace omnipoint::io
