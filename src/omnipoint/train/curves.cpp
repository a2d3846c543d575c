#include "omnipoint/train/curves.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

namespace omnipoint::train {
namespace {

using nlohmann::json;

struct Series {
  std::vector<std::pair<double, double>> points;  // (step, value)
  bool evaluation = false;
};

// The classic 5×7 dot-matrix glyphs (row bits, 0x10 = leftmost column) of the characters
// the labels use; anything else draws as a blank.
const std::map<char, std::array<uint8_t, 7>>& glyphs() {
  static const std::map<char, std::array<uint8_t, 7>> table{
      {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
      {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
      {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
      {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
      {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
      {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
      {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
      {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
      {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
      {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
      {'A', {0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11}},
      {'B', {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E}},
      {'C', {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}},
      {'D', {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C}},
      {'E', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}},
      {'F', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10}},
      {'G', {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F}},
      {'H', {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
      {'I', {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
      {'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C}},
      {'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}},
      {'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F}},
      {'M', {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}},
      {'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
      {'O', {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
      {'P', {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10}},
      {'Q', {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D}},
      {'R', {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11}},
      {'S', {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}},
      {'T', {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
      {'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
      {'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04}},
      {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}},
      {'X', {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11}},
      {'Y', {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04}},
      {'Z', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F}},
      {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
      {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}},
      {'+', {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00}},
      {':', {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00}},
      {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
      {'_', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F}},
      {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
      {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
  };
  return table;
}

struct Colour {
  uint8_t r, g, b;
};
constexpr Colour kInk{40, 40, 40}, kFrame{170, 170, 170}, kRaw{170, 195, 230}, kMean{25, 80, 170},
    kEval{200, 40, 40};

class Canvas {
 public:
  Canvas(int64_t width, int64_t height)
      : width_(width), height_(height), pixels_(width * height * 3, 255) {}

  void dot(int64_t x, int64_t y, Colour c) {
    if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
    uint8_t* p = &pixels_[(y * width_ + x) * 3];
    p[0] = c.r, p[1] = c.g, p[2] = c.b;
  }
  void line(double x0, double y0, double x1, double y1, Colour c) {
    const int64_t n =
        static_cast<int64_t>(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))) + 1;
    for (int64_t i = 0; i <= n; ++i) {
      const double t = static_cast<double>(i) / static_cast<double>(n);
      dot(std::lround(x0 + t * (x1 - x0)), std::lround(y0 + t * (y1 - y0)), c);
    }
  }
  void rect(int64_t x0, int64_t y0, int64_t x1, int64_t y1, Colour c) {
    line(x0, y0, x1, y0, c), line(x1, y0, x1, y1, c), line(x1, y1, x0, y1, c),
        line(x0, y1, x0, y0, c);
  }
  // Upper-cased text, 2× scaled glyphs, top-left at (x, y).
  void text(int64_t x, int64_t y, const std::string& text, Colour c) {
    for (const char raw : text) {
      const auto found =
          glyphs().find(static_cast<char>(std::toupper(static_cast<unsigned char>(raw))));
      if (found != glyphs().end())
        for (int row = 0; row < 7; ++row)
          for (int col = 0; col < 5; ++col)
            if (found->second[row] & (0x10 >> col))
              for (int k = 0; k < 4; ++k)
                dot(x + 2 * int64_t{col} + k % 2, y + 2 * int64_t{row} + k / 2, c);
      x += 12;
    }
  }
  at::Tensor tensor() const {
    return at::from_blob(const_cast<uint8_t*>(pixels_.data()), {height_, width_, 3}, at::kByte)
        .clone();
  }

 private:
  int64_t width_, height_;
  std::vector<uint8_t> pixels_;
};

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", value);
  return text;
}

void add_point(std::map<std::string, Series>& series, const std::string& name, double step,
               const json& value, bool evaluation) {
  if (!value.is_number()) return;
  const double v = value.get<double>();
  if (!std::isfinite(v)) return;
  Series& s = series[name];
  s.evaluation = evaluation;
  s.points.emplace_back(step, v);
}

// Of an evaluation, the total loss and the benchmark scores (`*_rel`, `*_delta1`); its loss
// terms would repeat the training panels.
bool is_eval_score(const std::string& name) {
  const auto ends_with = [&](const std::string& suffix) {
    return name.size() >= suffix.size() &&
           name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  return name == "loss" || ends_with("_rel") || ends_with("_delta1");
}

constexpr int64_t kPanelWidth = 400, kPanelHeight = 230, kColumns = 3;
constexpr int64_t kLeft = 12, kTop = 42, kRight = 12, kBottom = 28;  // plot area inside a panel

void draw_panel(Canvas& canvas, int64_t x0, int64_t y0, const std::string& name,
                const Series& series, double max_step) {
  const auto [low_it, high_it] =
      std::minmax_element(series.points.begin(), series.points.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; });
  const double low = low_it->second, high = high_it->second;
  const bool logarithmic = low > 0;
  const auto transform = [&](double v) { return logarithmic ? std::log(v) : v; };
  double bottom = transform(low), top = transform(high);
  if (top - bottom < 1e-12) bottom -= 0.5, top += 0.5;
  const double px0 = x0 + kLeft, px1 = x0 + kPanelWidth - kRight, py0 = y0 + kTop,
               py1 = y0 + kPanelHeight - kBottom;
  const auto x_of = [&](double step) { return px0 + (px1 - px0) * step / std::max(max_step, 1.0); };
  const auto y_of = [&](double v) {
    return py1 - (py1 - py0) * (transform(v) - bottom) / (top - bottom);
  };

  canvas.rect(static_cast<int64_t>(px0), static_cast<int64_t>(py0), static_cast<int64_t>(px1),
              static_cast<int64_t>(py1), kFrame);
  canvas.text(x0 + kLeft, y0 + 4, name + (logarithmic ? " (log)" : ""), kInk);
  canvas.text(x0 + kLeft, y0 + 22, number(low) + " - " + number(high), kFrame);
  canvas.text(x0 + kLeft, static_cast<int64_t>(py1) + 8, "0", kInk);
  const std::string steps = number(max_step);
  canvas.text(static_cast<int64_t>(px1) - 12 * static_cast<int64_t>(steps.size()),
              static_cast<int64_t>(py1) + 8, steps, kInk);

  const auto& points = series.points;
  if (series.evaluation) {
    for (const auto& [step, value] : points)
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
          canvas.dot(std::lround(x_of(step)) + dx, std::lround(y_of(value)) + dy, kEval);
    for (size_t i = 1; i < points.size(); ++i)
      canvas.line(x_of(points[i - 1].first), y_of(points[i - 1].second), x_of(points[i].first),
                  y_of(points[i].second), kEval);
    return;
  }
  for (size_t i = 1; i < points.size(); ++i)
    canvas.line(x_of(points[i - 1].first), y_of(points[i - 1].second), x_of(points[i].first),
                y_of(points[i].second), kRaw);
  // Running mean over a centred window of ~1/50 of the points.
  const int64_t half = std::max<int64_t>(1, static_cast<int64_t>(points.size()) / 100);
  std::vector<double> prefix(points.size() + 1, 0.0);
  for (size_t i = 0; i < points.size(); ++i) prefix[i + 1] = prefix[i] + points[i].second;
  double last_x = 0, last_y = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const int64_t a = std::max<int64_t>(0, static_cast<int64_t>(i) - half);
    const int64_t b =
        std::min<int64_t>(static_cast<int64_t>(points.size()), static_cast<int64_t>(i) + half + 1);
    const double mean = (prefix[b] - prefix[a]) / static_cast<double>(b - a);
    const double x = x_of(points[i].first), y = y_of(mean);
    if (i > 0) {
      canvas.line(last_x, last_y, x, y, kMean);
      canvas.line(last_x, last_y + 1, x, y + 1, kMean);
    }
    last_x = x, last_y = y;
  }
}

}  // namespace

at::Tensor render_training_curves(const std::vector<json>& records) {
  std::map<std::string, Series> train_series, eval_series;
  double max_step = 0;
  for (const json& record : records) {
    if (!record.is_object() || !record.contains("step") || !record.at("step").is_number()) continue;
    const double step = record.at("step").get<double>();
    max_step = std::max(max_step, step);
    if (record.contains("eval") && record.at("eval").is_object()) {
      for (const auto& [name, value] : record.at("eval").items())
        if (is_eval_score(name)) add_point(eval_series, "eval " + name, step, value, true);
      continue;
    }
    if (record.value("skipped", false)) continue;
    if (record.contains("loss")) add_point(train_series, "loss", step, record.at("loss"), false);
    if (record.contains("terms") && record.at("terms").is_object())
      for (const auto& [name, value] : record.at("terms").items())
        add_point(train_series, name, step, value, false);
  }
  // "loss" first, then the terms and the evaluations by name.
  std::vector<std::pair<std::string, const Series*>> panels;
  if (train_series.count("loss")) panels.emplace_back("loss", &train_series.at("loss"));
  for (const auto& [name, series] : train_series)
    if (name != "loss") panels.emplace_back(name, &series);
  for (const auto& [name, series] : eval_series) panels.emplace_back(name, &series);
  if (panels.empty())
    throw std::invalid_argument("training curves: the log holds no finite value to plot");

  const int64_t rows = (static_cast<int64_t>(panels.size()) + kColumns - 1) / kColumns;
  Canvas canvas(kColumns * kPanelWidth, rows * kPanelHeight);
  for (size_t i = 0; i < panels.size(); ++i)
    draw_panel(canvas, static_cast<int64_t>(i) % kColumns * kPanelWidth,
               static_cast<int64_t>(i) / kColumns * kPanelHeight, panels[i].first,
               *panels[i].second, max_step);
  return canvas.tensor();
}

}  // namespace omnipoint::train
