#include "omnipoint/io/image.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
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
#include "omnipoint/util/threads.h"
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
  const at::ScalarType type = image.scalar_type();
  const bool integer = type == at::kShort || type == at::kInt || type == at::kLong;
  if (!integer && type != at::kBool && type != at::kByte && !at::isFloatingType(type))
    bad("unsupported dtype (expected bool, uint8, int16/32/64 or floating)");
  const at::Tensor t = image.to(at::kCPU).contiguous();
  const bool sixteen = integer || (at::isFloatingType(type) && float_bits == 16);
  const int channels = t.dim() == 3 ? static_cast<int>(t.size(2)) : 1;
  const int rows = static_cast<int>(t.size(0)), cols = static_cast<int>(t.size(1));
  // One pass from the tensor into the PNG's pixels, RGB(A) to OpenCV's BGR(A) on the way.
  cv::Mat m(rows, cols, CV_MAKETYPE(sixteen ? CV_16U : CV_8U, channels));
  const int64_t count = t.numel();
  const auto target = [channels](int64_t i) {
    const int64_t c = i % channels;
    return channels >= 3 && c < 3 ? i - c + (2 - c) : i;
  };
  const auto fill = [&](auto* out, const auto& code) {
    util::parallel_for(0, count, 65536, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) out[target(i)] = code(i);
    });
  };
  if (type == at::kBool) {
    const bool* in = t.data_ptr<bool>();
    fill(m.ptr<uint8_t>(), [&](int64_t i) { return static_cast<uint8_t>(in[i] ? 255 : 0); });
  } else if (type == at::kByte) {
    const uint8_t* in = t.data_ptr<uint8_t>();
    fill(m.ptr<uint8_t>(), [&](int64_t i) { return in[i]; });
  } else if (integer) {
    std::atomic<bool> out_of_range{false};
    AT_DISPATCH_INTEGRAL_TYPES(type, "write_image_png", [&] {
      const scalar_t* in = t.data_ptr<scalar_t>();
      fill(m.ptr<uint16_t>(), [&](int64_t i) {
        // An int8 tensor holds numbers, not characters.
        const int64_t value = in[i];  // NOLINT(bugprone-signed-char-misuse)
        if (value < 0 || value > 65535) out_of_range = true;
        return static_cast<uint16_t>(std::clamp<int64_t>(value, 0, 65535));
      });
    });
    if (out_of_range) bad("16-bit values must lie in [0, 65535]");
  } else {
    const at::Tensor values = type == at::kDouble ? t : t.to(at::kFloat);
    const double top = float_bits == 16 ? 65535.0 : 255.0;
    std::atomic<bool> nan{false};
    AT_DISPATCH_FLOATING_TYPES(values.scalar_type(), "write_image_png", [&] {
      const scalar_t* in = values.data_ptr<scalar_t>();
      const auto code = [&](int64_t i) {
        const double value = in[i];
        if (std::isnan(value)) nan = true;
        return std::isnan(value) ? 0.0 : std::nearbyint(std::clamp(value, 0.0, 1.0) * top);
      };
      if (sixteen) {
        fill(m.ptr<uint16_t>(), [&](int64_t i) { return static_cast<uint16_t>(code(i)); });
      } else {
        fill(m.ptr<uint8_t>(), [&](int64_t i) { return static_cast<uint8_t>(code(i)); });
      }
    });
    if (nan) bad("the image contains NaN");
  }
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
