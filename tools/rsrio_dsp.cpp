// rsrio-dsp: runs the DSP stage on one raw radar frame and writes what it makes.
//
//   rsrio-dsp (--input REC.mcap [--frame N] | --npy FILE) (--radar PRESET | --config FILE) --out DIR
//
// Input: frame N (default 0) of the /radar/raw RadarFrame messages of a recording (its own radar
// configuration unless --radar or a `radar:` section of --config overrides it), or a raw frame
// stored as .npy ((loops, virtual, samples) or (loops, slots, rx, samples); OpenRadar's uint16 bit
// patterns are understood). The `dsp:` section of --config sets the DSP options.
//
// Output in DIR: ra.npy, rd.npy (float32; [range][azimuth], [range][doppler]), rad.npy with
// --rad ([range][doppler][azimuth]), axes.json (the grids), points.csv
// (range_m,azimuth_deg,elevation_deg,doppler_mps,snr_db), ra.png and rd.png (10 log10 power,
// labelled axes, colour bar). Grids and sign conventions: dsp/include/rsrio/dsp/processor.hpp.
//
// Exit codes: 0 done; 2 bad command line or configuration; 1 input or output failure.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "rsrio/common/cli.hpp"
#include "rsrio/common/log.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/dsp/dsp_options.hpp"
#include "rsrio/dsp/npy.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/recording/recording.hpp"

#ifndef RSRIO_DSP_HAVE_RECORDING
#define RSRIO_DSP_HAVE_RECORDING 1
#endif

namespace {

constexpr const char* kProgram = "rsrio-dsp";

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// ---- recordings ---------------------------------------------------------------------------------
// A template so that, in a build where rsrio_recording is still only its header, the recording
// code is compiled (names and types checked against recording.hpp) but never instantiated, and
// nothing refers to the library's symbols.
template <bool kEnabled>
rsrio_msgs::msg::RadarFrame read_recorded_frame(const std::string& path, long index) {
  if constexpr (kEnabled) {
    rsrio::RecordingReader reader(path);
    rsrio::RecordedMessage m;
    long seen = 0;
    while (reader.next(m)) {
      if (m.topic != rsrio::topics::kRadarRaw) continue;
      if (seen++ < index) continue;
      rsrio_msgs::msg::RadarFrame frame;
      if (!rsrio::decode(m, frame))
        throw InputError(path + ": message " + std::to_string(index) + " on " + rsrio::topics::kRadarRaw +
                         " is not a readable rsrio_msgs/msg/RadarFrame (schema '" + m.schema_name + "')");
      return frame;
    }
    std::string why = path + ": has " + std::to_string(seen) + " frame(s) on " + rsrio::topics::kRadarRaw +
                      ", frame " + std::to_string(index) + " asked for";
    if (reader.damage()) why += " (reading stopped at damage: " + reader.damage()->message() + ")";
    throw InputError(why);
  } else {
    (void)path;
    (void)index;
    throw InputError(
        "this build of rsrio-dsp cannot read recordings yet (rsrio_recording was not built when it "
        "was configured); use --npy, or rebuild once the recording library is in");
  }
}

// ---- output -------------------------------------------------------------------------------------
std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s << std::setprecision(9) << v;
  return s.str();
}

std::string json_array(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + json_number(v[i]);
  return s + "]";
}

void write_axes_json(const std::string& path, const rsrio::DspGrids& g, const rsrio::RadarConfig& c,
                     const std::string& source) {
  std::ofstream f(path);
  f << "{\n"
    << "  \"source\": \"" << source << "\",\n"
    << "  \"radar_preset\": \"" << c.preset << "\",\n"
    << "  \"frame\": \"radar frame: x forward, y left, z up; azimuth > 0 to the left; doppler > 0 "
       "receding\",\n"
    << "  \"range_m\": " << json_array(g.range_m) << ",\n"
    << "  \"azimuth_sin\": " << json_array(g.azimuth_sin) << ",\n"
    << "  \"azimuth_deg\": " << json_array(g.azimuth_deg) << ",\n"
    << "  \"doppler_mps\": " << json_array(g.doppler_mps) << ",\n"
    << "  \"range_bin_m\": " << json_number(g.range_bin_m) << ",\n"
    << "  \"velocity_bin_mps\": " << json_number(g.velocity_bin_mps) << ",\n"
    << "  \"azimuth_sin_bin\": " << json_number(g.azimuth_sin_bin) << ",\n"
    << "  \"azimuth_unambiguous_sin\": " << json_number(g.azimuth_unambiguous_sin) << ",\n"
    << "  \"ra\": {\"file\": \"ra.npy\", \"dtype\": \"float32\", \"shape\": [" << g.range_bins << ", "
    << g.azimuth_bins
    << "], \"axes\": [\"range_m\", \"azimuth_sin\"], \"value\": \"power summed over Doppler\"},\n"
    << "  \"rd\": {\"file\": \"rd.npy\", \"dtype\": \"float32\", \"shape\": [" << g.range_bins << ", "
    << g.doppler_bins
    << "], \"axes\": [\"range_m\", \"doppler_mps\"], \"value\": \"power summed over the virtual "
       "channels\"},\n"
    << "  \"rad\": {\"file\": \"rad.npy (with --rad)\", \"dtype\": \"float32\", \"shape\": [" << g.range_bins
    << ", " << g.doppler_bins << ", " << g.azimuth_bins
    << "], \"axes\": [\"range_m\", \"doppler_mps\", \"azimuth_sin\"]}\n"
    << "}\n";
  if (!f) throw InputError(path + ": write failed");
}

void write_points_csv(const std::string& path, std::span<const rsrio::DspPoint> points) {
  std::ofstream f(path);
  f << "range_m,azimuth_deg,elevation_deg,doppler_mps,snr_db,azimuth_ambiguous\n" << std::fixed;
  for (const auto& p : points)
    f << std::setprecision(4) << p.range_m << ',' << std::setprecision(3) << p.azimuth_deg << ','
      << p.elevation_deg << ',' << std::setprecision(4) << p.doppler_mps << ',' << std::setprecision(2)
      << p.snr_db << ',' << (p.azimuth_ambiguous ? 1 : 0) << '\n';
  if (!f) throw InputError(path + ": write failed");
}

double nice_step(double span, int ticks) {
  const double raw = span / std::max(1, ticks);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) return m * mag;
  return 10 * mag;
}

std::string fmt(double v) {
  std::ostringstream s;
  s << std::setprecision(3) << v;
  return s.str();
}

struct Axis {
  std::string label;
  // value at pixel centre of column / row i of the data (before flipping) and the ticks to draw:
  std::vector<std::pair<double, std::string>> ticks;  // (data index, text)
};

// A heatmap of 10 log10(power): data[rows][cols], row = range (drawn upwards), col = x axis
// (flipped left-right when flip_x). 60 dB of dynamic range under the maximum.
cv::Mat render(const float* data, int rows, int cols, bool flip_x, const std::string& title, const Axis& x,
               const Axis& y) {
  constexpr double kRangeDb = 60;
  cv::Mat db(rows, cols, CV_32F);
  double vmax = -std::numeric_limits<double>::infinity();
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const double v =
          10 * std::log10(std::max(1e-30, static_cast<double>(data[static_cast<std::size_t>(r) * cols + c])));
      db.at<float>(rows - 1 - r, flip_x ? cols - 1 - c : c) = static_cast<float>(v);
      vmax = std::max(vmax, v);
    }
  const double vmin = vmax - kRangeDb;
  cv::Mat u8;
  db.convertTo(u8, CV_8U, 255.0 / kRangeDb, -vmin * 255.0 / kRangeDb);
  cv::Mat colour;
  cv::applyColorMap(u8, colour, cv::COLORMAP_VIRIDIS);
  const int sx = std::max(1, 512 / cols), sy = std::max(1, 512 / rows);
  cv::Mat plot;
  cv::resize(colour, plot, cv::Size(cols * sx, rows * sy), 0, 0, cv::INTER_NEAREST);

  const int left = 70, right = 120, top = 36, bottom = 56;
  cv::Mat canvas(plot.rows + top + bottom, plot.cols + left + right, CV_8UC3, cv::Scalar(255, 255, 255));
  plot.copyTo(canvas(cv::Rect(left, top, plot.cols, plot.rows)));
  const cv::Scalar black(0, 0, 0);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  cv::rectangle(canvas, cv::Rect(left - 1, top - 1, plot.cols + 2, plot.rows + 2), black, 1);
  cv::putText(canvas, title, cv::Point(left, 24), font, 0.55, black, 1, cv::LINE_AA);
  for (const auto& [idx, text] : x.ticks) {
    const double col = flip_x ? cols - 1 - idx : idx;
    const int px = left + static_cast<int>(std::lround((col + 0.5) * sx));
    cv::line(canvas, cv::Point(px, top + plot.rows), cv::Point(px, top + plot.rows + 5), black, 1);
    int base = 0;
    const cv::Size ts = cv::getTextSize(text, font, 0.4, 1, &base);
    cv::putText(canvas, text, cv::Point(px - ts.width / 2, top + plot.rows + 18), font, 0.4, black, 1,
                cv::LINE_AA);
  }
  {
    int base = 0;
    const cv::Size ts = cv::getTextSize(x.label, font, 0.45, 1, &base);
    cv::putText(canvas, x.label, cv::Point(left + plot.cols / 2 - ts.width / 2, top + plot.rows + 42), font,
                0.45, black, 1, cv::LINE_AA);
  }
  for (const auto& [idx, text] : y.ticks) {
    const int py = top + plot.rows - static_cast<int>(std::lround((idx + 0.5) * sy));
    cv::line(canvas, cv::Point(left - 5, py), cv::Point(left, py), black, 1);
    int base = 0;
    const cv::Size ts = cv::getTextSize(text, font, 0.4, 1, &base);
    cv::putText(canvas, text, cv::Point(left - 8 - ts.width, py + 4), font, 0.4, black, 1, cv::LINE_AA);
  }
  {
    // y label, rotated
    int base = 0;
    const cv::Size ts = cv::getTextSize(y.label, font, 0.45, 1, &base);
    cv::Mat lab(ts.height + base + 4, ts.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(lab, y.label, cv::Point(2, ts.height + 1), font, 0.45, black, 1, cv::LINE_AA);
    cv::Mat rot;
    cv::rotate(lab, rot, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int y0 = std::max(0, top + plot.rows / 2 - rot.rows / 2);
    if (y0 + rot.rows <= canvas.rows) rot.copyTo(canvas(cv::Rect(6, y0, rot.cols, rot.rows)));
  }
  // colour bar
  const int bx = left + plot.cols + 20, bw = 18;
  cv::Mat grad(plot.rows, 1, CV_8U);
  for (int i = 0; i < plot.rows; ++i)
    grad.at<unsigned char>(i, 0) = static_cast<unsigned char>(255 - i * 255 / std::max(1, plot.rows - 1));
  cv::Mat grad_c;
  cv::applyColorMap(grad, grad_c, cv::COLORMAP_VIRIDIS);
  cv::resize(grad_c, grad_c, cv::Size(bw, plot.rows), 0, 0, cv::INTER_NEAREST);
  grad_c.copyTo(canvas(cv::Rect(bx, top, bw, plot.rows)));
  cv::rectangle(canvas, cv::Rect(bx - 1, top - 1, bw + 2, plot.rows + 2), black, 1);
  for (int k = 0; k <= 6; ++k) {
    const double v = vmax - k * 10;
    const int py = top + static_cast<int>(std::lround(k * 10 / kRangeDb * (plot.rows - 1)));
    cv::line(canvas, cv::Point(bx + bw, py), cv::Point(bx + bw + 4, py), black, 1);
    cv::putText(canvas, fmt(std::round(v)), cv::Point(bx + bw + 7, py + 4), font, 0.38, black, 1,
                cv::LINE_AA);
  }
  cv::putText(canvas, "dB", cv::Point(bx, top + plot.rows + 18), font, 0.4, black, 1, cv::LINE_AA);
  return canvas;
}

Axis range_axis(const rsrio::DspGrids& g) {
  Axis a;
  a.label = "range [m]";
  const double rmax = g.range_m.back();
  const double step = nice_step(rmax, 6);
  for (double v = 0; v <= rmax + 1e-9; v += step) a.ticks.emplace_back(v / g.range_bin_m, fmt(v));
  return a;
}

Axis azimuth_axis(const rsrio::DspGrids& g) {
  Axis a;
  a.label = "azimuth [deg] (+ left)";
  const double d = g.element_spacing_wavelengths;
  for (double deg = -90; deg <= 90; deg += 30) {
    const double s = std::sin(deg * std::numbers::pi / 180);
    const double idx = s * g.azimuth_bins * d + g.azimuth_bins / 2;
    if (idx >= -0.5 && idx <= g.azimuth_bins - 0.5) a.ticks.emplace_back(idx, fmt(deg));
  }
  return a;
}

Axis doppler_axis(const rsrio::DspGrids& g) {
  Axis a;
  a.label = "Doppler velocity [m/s] (+ receding)";
  const double vmax = g.velocity_bin_mps * g.doppler_bins / 2;
  const double step = nice_step(2 * vmax, 6);
  for (double v = -std::floor(vmax / step) * step; v <= vmax + 1e-9; v += step)
    a.ticks.emplace_back(v / g.velocity_bin_mps + g.doppler_bins / 2, fmt(std::fabs(v) < 1e-12 ? 0.0 : v));
  return a;
}

void write_png(const std::string& path, const cv::Mat& img) {
  if (!cv::imwrite(path, img)) throw InputError(path + ": could not write the PNG");
}

}  // namespace

int main(int argc, char** argv) {
  std::string input, frame_text, npy, radar_name, out_dir;
  bool write_rad = false;
  rsrio::Cli cli(
      kProgram,
      "Run the DSP stage (range / Doppler / angle FFTs, CFAR) on one raw radar frame and write the RA and "
      "RD images (.npy and .png), their axes (axes.json) and the CFAR points (points.csv).\n"
      "Input: --input REC.mcap [--frame N] or --npy FILE. Radar: --radar PRESET, or a `radar:` section in "
      "--config (for --input the recording's own configuration is the default). DSP options: the `dsp:` "
      "section of --config.");
  cli.option("--input", "REC.mcap", "a recording: reads its /radar/raw frames", &input)
      .option("--frame", "N", "which /radar/raw frame of --input (0-based, default 0)", &frame_text)
      .option("--npy", "FILE",
              "a raw frame as .npy, (loops, virtual, samples) or (loops, slots, rx, samples)", &npy)
      .option("--radar", "PRESET",
              "built-in radar preset: xwr1843 or mmwcas (overrides any other radar configuration)",
              &radar_name)
      .option("--out", "DIR", "output directory (created if needed)", &out_dir)
      .flag("--rad", "also write the RAD cube as rad.npy", &write_rad);
  if (auto rc = cli.parse(argc, argv)) return *rc;

  if (input.empty() == npy.empty()) return cli.usage_error("give exactly one of --input REC.mcap and --npy FILE");
  if (out_dir.empty()) return cli.usage_error("missing --out DIR");
  long frame_index = 0;
  if (!frame_text.empty()) {
    if (input.empty()) return cli.usage_error("--frame goes with --input");
    char* end = nullptr;
    frame_index = std::strtol(frame_text.c_str(), &end, 10);
    if (!end || *end || frame_index < 0)
      return cli.usage_error("--frame: expected a non-negative integer, got '" + frame_text + "'");
  }

  std::optional<rsrio::RadarConfig> radar;
  rsrio::DspOptions dsp_options;
  if (auto rc = rsrio::load_program_config(cli, kProgram, [&](rsrio::OptionsNode& root) {
        if (root.has("radar")) {
          rsrio::OptionsNode r = root.child("radar");
          radar = rsrio::load_radar_config(r);
        }
        rsrio::OptionsNode d = root.child("dsp");
        dsp_options = rsrio::load_dsp_options(d);
      }))
    return *rc;
  if (!radar_name.empty()) {
    try {
      radar = rsrio::radar_preset(radar_name);
    } catch (const std::invalid_argument&) {
      return cli.usage_error("--radar: expected one of xwr1843 mmwcas, got '" + radar_name + "'");
    }
  }
  if (!npy.empty() && !radar)
    return cli.usage_error("--npy needs a radar configuration: --radar PRESET or a `radar:` section in --config FILE");

  try {
    rsrio::AdcCube cube;
    std::string source;
    if (!input.empty()) {
      const rsrio_msgs::msg::RadarFrame frame =
          read_recorded_frame<RSRIO_DSP_HAVE_RECORDING != 0>(input, frame_index);
      if (!radar) {
        if constexpr (RSRIO_DSP_HAVE_RECORDING != 0) radar = rsrio::from_msg(frame.config());
      }
      if (frame.flags() & rsrio_msgs::msg::RadarFrame_Constants::FLAG_DAMAGED)
        spdlog::warn("frame {} of {} is flagged damaged ({} bytes zero-filled)", frame_index, input,
                     frame.lost_bytes());
      const std::size_t need = rsrio::raw_frame_bytes(*radar);
      if (frame.adc().size() != need)
        throw InputError(input + ": frame " + std::to_string(frame_index) + " holds " +
                         std::to_string(frame.adc().size()) + " bytes, the radar configuration needs " +
                         std::to_string(need));
      rsrio::decode_frame(*radar, frame.adc(), cube);
      source = input + " frame " + std::to_string(frame_index);
    } else {
      bool patterns = false;
      cube = rsrio::npy_to_cube(rsrio::read_npy(npy), *radar, npy, &patterns);
      if (patterns)
        spdlog::info("{}: int16 samples stored as uint16 bit patterns (OpenRadar), converted", npy);
      source = npy;
    }

    rsrio::DspProcessor dsp(*radar, dsp_options);
    std::ostringstream cfg;
    rsrio::print(cfg, dsp_options);
    std::cout << "# " << kProgram << ": " << source << "\n" << cfg.str();
    const rsrio::RadarDerived der = rsrio::derive(*radar);
    std::cout << "# radar " << radar->preset << ": " << der.num_tx << " TX slots x " << der.num_rx
              << " RX, range bin " << der.range_bin_size_m << " m, velocity bin " << der.velocity_bin_size_mps
              << " m/s, " << radar->angle_fft_size << " azimuth bins\n";
    const rsrio::DspResult& res = dsp.process(cube);
    const rsrio::DspGrids& g = dsp.grids();

    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec) throw InputError(out_dir + ": cannot create the output directory (" + ec.message() + ")");
    const std::filesystem::path dir(out_dir);
    const auto Nr = static_cast<std::size_t>(g.range_bins), Na = static_cast<std::size_t>(g.azimuth_bins),
               Nd = static_cast<std::size_t>(g.doppler_bins);
    rsrio::write_npy((dir / "ra.npy").string(), res.ra.data(), {Nr, Na});
    rsrio::write_npy((dir / "rd.npy").string(), res.rd.data(), {Nr, Nd});
    if (write_rad) rsrio::write_npy((dir / "rad.npy").string(), res.rad.data(), {Nr, Nd, Na});
    write_axes_json((dir / "axes.json").string(), g, *radar, source);
    write_points_csv((dir / "points.csv").string(), res.points);
    write_png((dir / "ra.png").string(),
              render(res.ra.data(), g.range_bins, g.azimuth_bins, true,
                     "range-azimuth power (sum over Doppler)", azimuth_axis(g), range_axis(g)));
    write_png((dir / "rd.png").string(),
              render(res.rd.data(), g.range_bins, g.doppler_bins, false,
                     "range-Doppler power (sum over channels)", doppler_axis(g), range_axis(g)));
    std::cout << "# " << res.detections.size() << " CFAR detections, " << res.points.size() << " points -> "
              << out_dir << "/{ra.npy, rd.npy, axes.json, points.csv, ra.png, rd.png"
              << (write_rad ? ", rad.npy" : "") << "}\n";
  } catch (...) {
    return rsrio::report_program_error(kProgram, std::current_exception());
  }
  return 0;
}
