#include "rsrio/eval/plot.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace rsrio::eval {

void plot_xy(const std::string& path, const std::vector<PlotLine>& lines, const std::string& title, int width_px,
             const PlotPoints* points) {
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto& l : lines)
    for (const auto& p : *l.trajectory) {
      xmin = std::min(xmin, p.p.x());
      xmax = std::max(xmax, p.p.x());
      ymin = std::min(ymin, p.p.y());
      ymax = std::max(ymax, p.p.y());
    }
  if (points != nullptr)
    for (const auto& p : points->xy) {
      xmin = std::min(xmin, p.x());
      xmax = std::max(xmax, p.x());
      ymin = std::min(ymin, p.y());
      ymax = std::max(ymax, p.y());
    }
  if (xmin > xmax) xmin = ymin = -1, xmax = ymax = 1;
  const double span = std::max({xmax - xmin, ymax - ymin, 1.0}) * 1.1;
  const double cx = 0.5 * (xmin + xmax), cy = 0.5 * (ymin + ymax);
  const int margin = 70, plot = width_px - 2 * margin;
  const int height_px = width_px + 40;
  cv::Mat img(height_px, width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  const double scale = plot / span;
  auto px = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround(margin + (x - (cx - span / 2)) * scale)),
                     static_cast<int>(std::lround(40 + margin + ((cy + span / 2) - y) * scale)));
  };
  // Grid step: 1, 2, 5 x 10^k metres, about 8 lines across.
  double step = std::pow(10.0, std::floor(std::log10(span / 8)));
  if (span / step > 16) step *= 5;
  else if (span / step > 8) step *= 2;
  const cv::Scalar grid(225, 225, 225), ink(40, 40, 40);
  for (double g = std::ceil((cx - span / 2) / step) * step; g <= cx + span / 2; g += step) {
    cv::line(img, px(g, cy - span / 2), px(g, cy + span / 2), grid, 1);
    if (std::abs(g) < step * 1e-6) g = 0;  // no "-0" labels
    cv::putText(img, cv::format("%g", g), px(g, cy - span / 2) + cv::Point(-12, 18), cv::FONT_HERSHEY_SIMPLEX, 0.4, ink);
  }
  for (double g = std::ceil((cy - span / 2) / step) * step; g <= cy + span / 2; g += step) {
    cv::line(img, px(cx - span / 2, g), px(cx + span / 2, g), grid, 1);
    if (std::abs(g) < step * 1e-6) g = 0;
    cv::putText(img, cv::format("%g", g), px(cx - span / 2, g) + cv::Point(-50, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4, ink);
  }
  cv::rectangle(img, px(cx - span / 2, cy + span / 2), px(cx + span / 2, cy - span / 2), ink, 1);
  cv::putText(img, "x [m]", cv::Point(width_px / 2 - 20, height_px - 15), cv::FONT_HERSHEY_SIMPLEX, 0.5, ink);
  cv::putText(img, "y [m]", cv::Point(8, 40 + margin - 10), cv::FONT_HERSHEY_SIMPLEX, 0.5, ink);
  cv::putText(img, title, cv::Point(margin, 30), cv::FONT_HERSHEY_SIMPLEX, 0.6, ink, 1, cv::LINE_AA);
  if (points != nullptr)
    for (std::size_t i = 0; i < points->xy.size(); ++i) {
      const double w = i < points->weight.size() ? std::clamp(points->weight[i], 0.0, 1.0) : 1.0;
      const double grey = 220 - 200 * w;
      cv::circle(img, px(points->xy[i].x(), points->xy[i].y()), 1, cv::Scalar(grey, grey, grey), cv::FILLED);
    }
  int legend_y = 40 + margin + 20;
  for (const auto& l : lines) {
    std::vector<cv::Point> pts;
    for (const auto& p : *l.trajectory) pts.push_back(px(p.p.x(), p.p.y()));
    if (pts.size() > 1) cv::polylines(img, pts, false, l.colour, 2, cv::LINE_AA);
    if (!pts.empty()) cv::circle(img, pts.front(), 5, l.colour, cv::FILLED);
    cv::line(img, {margin + 15, legend_y}, {margin + 45, legend_y}, l.colour, 3);
    cv::putText(img, l.label, {margin + 52, legend_y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.5, ink, 1, cv::LINE_AA);
    legend_y += 22;
  }
  if (!cv::imwrite(path, img)) throw std::runtime_error(path + ": cannot write the plot");
}

}  // namespace rsrio::eval
