#include "rsrio/dsp/dsp_options.hpp"

#include <iomanip>
#include <ostream>

#include "rsrio/common/options.hpp"

namespace rsrio {

namespace {
constexpr std::initializer_list<std::string_view> kWindows = {"none", "hann", "hamming", "blackman"};
}

DspOptions load_dsp_options(OptionsNode& node) {
  DspOptions o;
  node.read_choice("range_window", o.range_window, kWindows);
  node.read_choice("doppler_window", o.doppler_window, kWindows);
  node.read_choice("angle_window", o.angle_window, kWindows);
  node.read("dc_removal", o.dc_removal);
  node.read("clutter_removal", o.clutter_removal);
  node.read("tdm_compensation", o.tdm_compensation);
  node.read("calibration", o.calibration);
  node.read_choice("fft_planning", o.fft_planning, {"estimate", "measure"});
  node.read_choice("interpolation", o.interpolation, {"calibrated", "gaussian", "none"});
  node.read("doppler_own_peak", o.doppler_own_peak);
  node.read("max_angle_peaks", o.max_angle_peaks, {1, 16});
  node.read("angle_peak_db", o.angle_peak_db, {0.0, 60.0});

  OptionsNode c = node.child("cfar");
  CfarOptions& cf = o.cfar;
  c.read_choice("type", cf.type, {"ca", "os"});
  c.read_choice("mode", cf.mode, {"2d", "dual_pass"});
  c.read("pfa", cf.pfa, {1e-12, 0.1});
  c.read("guard_range", cf.guard_range, {0, 64});
  c.read("train_range", cf.train_range, {1, 128});
  c.read("guard_doppler", cf.guard_doppler, {0, 64});
  c.read("train_doppler", cf.train_doppler, {1, 128});
  c.read("os_rank", cf.os_rank, {0.05, 1.0});
  c.read("discard_near_bins", cf.discard_near_bins, {0, 4096});
  c.read("discard_far_bins", cf.discard_far_bins, {-1, 4096});
  c.read("peak_grouping", cf.peak_grouping);
  c.read("max_detections", cf.max_detections, {1, 1 << 20});
  c.finish();
  node.finish();
  validate(o, node.file());
  return o;
}

void validate(const DspOptions& o, const std::string& file) {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(file, "dsp." + key, what);
  };
  auto window = [&](const std::string& key, const std::string& v) {
    for (auto w : kWindows)
      if (v == w) return;
    fail(key, "one of 'none' 'hann' 'hamming' 'blackman', got '" + v + "'");
  };
  window("range_window", o.range_window);
  window("doppler_window", o.doppler_window);
  window("angle_window", o.angle_window);
  if (o.fft_planning != "estimate" && o.fft_planning != "measure")
    fail("fft_planning", "one of 'estimate' 'measure', got '" + o.fft_planning + "'");
  if (o.interpolation != "calibrated" && o.interpolation != "gaussian" && o.interpolation != "none")
    fail("interpolation", "one of 'calibrated' 'gaussian' 'none', got '" + o.interpolation + "'");
  if (o.max_angle_peaks < 1 || o.max_angle_peaks > 16) fail("max_angle_peaks", "an integer in [1, 16]");
  if (!(o.angle_peak_db >= 0 && o.angle_peak_db <= 60)) fail("angle_peak_db", "a number in [0, 60]");
  const CfarOptions& c = o.cfar;
  if (c.type != "ca" && c.type != "os") fail("cfar.type", "one of 'ca' 'os', got '" + c.type + "'");
  if (c.mode != "2d" && c.mode != "dual_pass")
    fail("cfar.mode", "one of '2d' 'dual_pass', got '" + c.mode + "'");
  if (!(c.pfa >= 1e-12 && c.pfa <= 0.1)) fail("cfar.pfa", "a probability in [1e-12, 0.1]");
  if (c.guard_range < 0 || c.guard_doppler < 0)
    fail(c.guard_range < 0 ? "cfar.guard_range" : "cfar.guard_doppler", "an integer >= 0");
  if (c.train_range < 1) fail("cfar.train_range", "an integer >= 1");
  if (c.train_doppler < 1) fail("cfar.train_doppler", "an integer >= 1");
  if (!(c.os_rank >= 0.05 && c.os_rank <= 1.0)) fail("cfar.os_rank", "a number in [0.05, 1]");
  if (c.discard_near_bins < 0) fail("cfar.discard_near_bins", "an integer >= 0");
  if (c.discard_far_bins < -1) fail("cfar.discard_far_bins", "an integer >= 0, or -1 for automatic");
  if (c.max_detections < 1) fail("cfar.max_detections", "an integer >= 1");
}

void print(std::ostream& out, const DspOptions& o) {
  auto b = [](bool v) { return v ? "true" : "false"; };
  const CfarOptions& c = o.cfar;
  out << std::setprecision(6);
  out << "dsp:\n"
      << "  range_window: " << o.range_window << "\n"
      << "  doppler_window: " << o.doppler_window << "\n"
      << "  angle_window: " << o.angle_window << "\n"
      << "  dc_removal: " << b(o.dc_removal) << "\n"
      << "  clutter_removal: " << b(o.clutter_removal) << "\n"
      << "  tdm_compensation: " << b(o.tdm_compensation) << "\n"
      << "  calibration: " << b(o.calibration) << "\n"
      << "  fft_planning: " << o.fft_planning << "\n"
      << "  interpolation: " << o.interpolation << "\n"
      << "  doppler_own_peak: " << b(o.doppler_own_peak) << "\n"
      << "  max_angle_peaks: " << o.max_angle_peaks << "\n"
      << "  angle_peak_db: " << o.angle_peak_db << "\n"
      << "  cfar:\n"
      << "    type: " << c.type << "\n"
      << "    mode: \"" << c.mode << "\"\n"  // quoted: cv::FileStorage reads a bare 2d as a number
      << "    pfa: " << c.pfa << "\n"
      << "    guard_range: " << c.guard_range << "\n"
      << "    train_range: " << c.train_range << "\n"
      << "    guard_doppler: " << c.guard_doppler << "\n"
      << "    train_doppler: " << c.train_doppler << "\n"
      << "    os_rank: " << c.os_rank << "\n"
      << "    discard_near_bins: " << c.discard_near_bins << "\n"
      << "    discard_far_bins: " << c.discard_far_bins << "\n"
      << "    peak_grouping: " << b(c.peak_grouping) << "\n"
      << "    max_detections: " << c.max_detections << "\n";
}

}  // namespace rsrio
