#include "rsrio/splat/image_dump.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "rsrio/splat/backend.hpp"
#include "rsrio/splat/losses.hpp"

namespace rsrio::splat {

namespace {

// dB image -> 8-bit over [top - range, top], rows flipped so that far range is at the top.
cv::Mat to_u8(const Image<float>& linear, double gain, double top_db, double range_db) {
  cv::Mat out(static_cast<int>(linear.rows()), static_cast<int>(linear.cols()), CV_8UC1);
  for (int r = 0; r < out.rows; ++r) {
    for (int c = 0; c < out.cols; ++c) {
      const double v = std::max(static_cast<double>(linear(r, c)) * gain, 1e-30);
      const double db = 10.0 * std::log10(v);
      const double x = std::clamp((db - (top_db - range_db)) / range_db, 0.0, 1.0);
      out.at<std::uint8_t>(out.rows - 1 - r, c) = static_cast<std::uint8_t>(std::lround(255.0 * x));
    }
  }
  return out;
}

}  // namespace

void write_image_pair_png(const std::string& path, const Image<float>& measured, const Image<float>& rendered,
                          const ImagePairOptions& o) {
  if (measured.size() == 0 || measured.rows() != rendered.rows() || measured.cols() != rendered.cols())
    throw std::runtime_error(path + ": measured and rendered images are empty or differ in shape");
  const double ref_m = percentile_reference({measured.data(), static_cast<std::size_t>(measured.size())},
                                            o.reference_percentile);
  const double ref_r = percentile_reference({rendered.data(), static_cast<std::size_t>(rendered.size())},
                                            o.reference_percentile);
  const double gain = o.match_levels && ref_r > 0 ? ref_m / ref_r : 1.0;
  const double top_db = 10.0 * std::log10(std::max(static_cast<double>(measured.maxCoeff()), 1e-30));
  cv::Mat left = to_u8(measured, 1.0, top_db, o.dynamic_range_db);
  cv::Mat right = to_u8(rendered, gain, top_db, o.dynamic_range_db);
  cv::Mat both, big, colour;
  cv::Mat gap(left.rows, 2, CV_8UC1, cv::Scalar(255));
  cv::hconcat(std::vector<cv::Mat>{left, gap, right}, both);
  cv::resize(both, big, cv::Size(), o.scale, o.scale, cv::INTER_NEAREST);
  cv::applyColorMap(big, colour, cv::COLORMAP_INFERNO);
  if (!cv::imwrite(path, colour)) throw std::runtime_error(path + ": cannot write the image");
}

void write_keyframe_pngs(const std::string& prefix, const KeyframeRender& render, const ImagePairOptions& options) {
  write_image_pair_png(prefix + "_ra.png", render.ra_measured, render.ra_rendered, options);
  write_image_pair_png(prefix + "_rd.png", render.rd_measured, render.rd_rendered, options);
}

}  // namespace rsrio::splat
