// Pictures of what the backend sees: measured vs rendered RA and RD images of a keyframe
// (SPEC Sec. 11), as PNG through OpenCV.
//
// Layout of the picture: two panels side by side, measured (left) and rendered (right), each
// [range][column] with range growing UPWARDS (far at the top, as a radar display), in dB over a
// common range: [max - dynamic_range_db, max] of the measured image, so that the two panels share
// one colour scale (the rendered image is first matched to the measured one by their
// `reference_percentile`s, as the loss's fixed references do). Colour map: OpenCV's
// COLORMAP_INFERNO. Each pixel of the images becomes scale x scale pixels.
#pragma once

#include <string>

#include "rsrio/splat/grid.hpp"

namespace rsrio::splat {

struct KeyframeRender;

struct ImagePairOptions {
  double dynamic_range_db = 40.0;
  double reference_percentile = 99.0;
  int scale = 3;  // pixels per image pixel (RA 256 x 64 is small)
  bool match_levels = true;
};

/// Writes measured | rendered side by side to `path` (PNG). Throws std::runtime_error when the
/// images are empty or differ in shape, or the file cannot be written.
void write_image_pair_png(const std::string& path, const Image<float>& measured, const Image<float>& rendered,
                          const ImagePairOptions& options = {});

/// `prefix` + "_ra.png" and `prefix` + "_rd.png" for a keyframe (Backend::render_keyframe).
void write_keyframe_pngs(const std::string& prefix, const KeyframeRender& render, const ImagePairOptions& options = {});

}  // namespace rsrio::splat
