// Trajectory pictures (PNG through OpenCV): trajectories from above with a metre grid and a legend.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "rsrio/eval/trajectory.hpp"

namespace rsrio::eval {

struct PlotLine {
  std::string label;
  const Trajectory* trajectory;
  cv::Scalar colour;  // BGR
};

/// Points drawn under the lines (a map from above): x, y and a weight in [0, 1] (darker = more).
struct PlotPoints {
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> weight;
};

/// Draws the xy plane, equal axes, a grid every 1/2/5/10... m, axis labels and a legend, and the
/// points (if any) beneath; writes `path` (PNG). Throws std::runtime_error when the file cannot be
/// written.
void plot_xy(const std::string& path, const std::vector<PlotLine>& lines, const std::string& title,
             int width_px = 1000, const PlotPoints* points = nullptr);

}  // namespace rsrio::eval
