// rsrio::RadarConfig <-> rsrio_msgs::msg::RadarConfig.
//
// A configuration read back from a recording is untrusted input, like an options file: from_msg
// applies the same ranges and choices load_radar_config() applies to the `radar` section (they
// bound the buffers the DSP sizes from these numbers), then validate().
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "rsrio/common/options.hpp"
#include "rsrio/recording/recording.hpp"

namespace rsrio {

namespace {

const std::string kRecordingFile = "<recording>";

[[noreturn]] void fail(const std::string& key, const std::string& expected) {
  throw ConfigError(kRecordingFile, "radar." + key, expected);
}

std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

int checked_int(std::int64_t value, const std::string& key, std::int64_t min, std::int64_t max) {
  if (value < min || value > max)
    fail(key, "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "], got " + std::to_string(value));
  return static_cast<int>(value);
}

double checked_real(double value, const std::string& key, double min, double max) {
  if (!std::isfinite(value) || value < min || value > max)
    fail(key, "a number in [" + number_text(min) + ", " + number_text(max) + "], got " + number_text(value));
  return value;
}

std::vector<int> checked_ints(const std::vector<std::int32_t>& values, const std::string& key, int min, int max) {
  std::vector<int> out;
  out.reserve(values.size());
  for (std::int32_t v : values) out.push_back(checked_int(v, key, min, max));
  return out;
}

std::vector<double> checked_reals(const std::vector<double>& values, const std::string& key) {
  for (double v : values)
    if (!std::isfinite(v)) fail(key, "finite numbers, got " + number_text(v));
  return values;
}

std::string checked_choice(const std::string& value, const std::string& key,
                           std::initializer_list<std::string_view> choices) {
  std::string listed;
  for (std::string_view choice : choices) {
    if (value == choice) return value;
    listed += (listed.empty() ? "'" : " '") + std::string(choice) + "'";
  }
  fail(key, "one of " + listed + ", got '" + value + "'");
}

}  // namespace

rsrio_msgs::msg::RadarConfig to_msg(const RadarConfig& config) {
  rsrio_msgs::msg::RadarConfig msg;
  msg.preset(config.preset);
  msg.start_frequency_ghz(config.chirp.start_frequency_ghz);
  msg.slope_mhz_per_us(config.chirp.slope_mhz_per_us);
  msg.adc_sample_rate_ksps(config.chirp.adc_sample_rate_ksps);
  msg.samples_per_chirp(static_cast<std::uint32_t>(config.chirp.samples_per_chirp));
  msg.idle_time_us(config.chirp.idle_time_us);
  msg.adc_start_time_us(config.chirp.adc_start_time_us);
  msg.ramp_end_time_us(config.chirp.ramp_end_time_us);
  msg.loops(static_cast<std::uint32_t>(config.loops));
  msg.tx_order(std::vector<std::int32_t>(config.tx_order.begin(), config.tx_order.end()));
  msg.frame_period_ms(config.frame_period_ms);
  msg.angle_fft_size(static_cast<std::uint32_t>(config.angle_fft_size));
  msg.design_frequency_ghz(config.array.design_frequency_ghz);
  msg.tx_azimuth(std::vector<std::int32_t>(config.array.tx_azimuth.begin(), config.array.tx_azimuth.end()));
  msg.tx_elevation(std::vector<std::int32_t>(config.array.tx_elevation.begin(), config.array.tx_elevation.end()));
  msg.rx_azimuth(std::vector<std::int32_t>(config.array.rx_azimuth.begin(), config.array.rx_azimuth.end()));
  msg.rx_elevation(std::vector<std::int32_t>(config.array.rx_elevation.begin(), config.array.rx_elevation.end()));
  msg.capture_format(config.capture.format);
  msg.iq_order(config.capture.iq_order);
  msg.sample_layout(config.capture.sample_layout);
  msg.offset_binary(config.capture.offset_binary);
  msg.lvds_lanes(static_cast<std::uint8_t>(config.capture.lvds_lanes));
  std::vector<double> gain_re;
  std::vector<double> gain_im;
  gain_re.reserve(config.calibration.gain.size());
  gain_im.reserve(config.calibration.gain.size());
  for (const std::complex<double>& g : config.calibration.gain) {
    gain_re.push_back(g.real());
    gain_im.push_back(g.imag());
  }
  msg.calibration_gain_re(std::move(gain_re));
  msg.calibration_gain_im(std::move(gain_im));
  msg.calibration_frequency_offset_hz(config.calibration.frequency_offset_hz);
  return msg;
}

RadarConfig from_msg(const rsrio_msgs::msg::RadarConfig& msg) {
  RadarConfig config;
  config.preset = msg.preset();
  // The ranges of load_radar_config() (common/src/radar_config.cpp).
  config.chirp.start_frequency_ghz = checked_real(msg.start_frequency_ghz(), "chirp.start_frequency_ghz", 1.0, 300.0);
  config.chirp.slope_mhz_per_us = checked_real(msg.slope_mhz_per_us(), "chirp.slope_mhz_per_us", 1.0, 300.0);
  config.chirp.adc_sample_rate_ksps =
      checked_real(msg.adc_sample_rate_ksps(), "chirp.adc_sample_rate_ksps", 100.0, 50000.0);
  config.chirp.samples_per_chirp = checked_int(msg.samples_per_chirp(), "chirp.samples_per_chirp", 16, 4096);
  config.chirp.idle_time_us = checked_real(msg.idle_time_us(), "chirp.idle_time_us", 2.0, 5000.0);
  config.chirp.adc_start_time_us = checked_real(msg.adc_start_time_us(), "chirp.adc_start_time_us", 0.0, 1000.0);
  config.chirp.ramp_end_time_us = checked_real(msg.ramp_end_time_us(), "chirp.ramp_end_time_us", 1.0, 5000.0);
  config.loops = checked_int(msg.loops(), "loops", 1, 1024);
  config.tx_order = checked_ints(msg.tx_order(), "tx_order", 0, 63);
  config.frame_period_ms = checked_real(msg.frame_period_ms(), "frame_period_ms", 1.0, 10000.0);
  config.angle_fft_size = checked_int(msg.angle_fft_size(), "angle_fft_size", 2, 4096);
  config.array.design_frequency_ghz =
      checked_real(msg.design_frequency_ghz(), "array.design_frequency_ghz", 1.0, 300.0);
  config.array.tx_azimuth = checked_ints(msg.tx_azimuth(), "array.tx_azimuth", -1000, 1000);
  config.array.tx_elevation = checked_ints(msg.tx_elevation(), "array.tx_elevation", -1000, 1000);
  config.array.rx_azimuth = checked_ints(msg.rx_azimuth(), "array.rx_azimuth", -1000, 1000);
  config.array.rx_elevation = checked_ints(msg.rx_elevation(), "array.rx_elevation", -1000, 1000);
  config.capture.format = checked_choice(msg.capture_format(), "capture.format", {"dca1000", "mmwcas"});
  config.capture.iq_order = checked_choice(msg.iq_order(), "capture.iq_order", {"i_first", "q_first"});
  config.capture.sample_layout = checked_choice(msg.sample_layout(), "capture.sample_layout", {"iiqq", "iq"});
  config.capture.offset_binary = msg.offset_binary();
  config.capture.lvds_lanes = msg.lvds_lanes();
  if (config.capture.lvds_lanes != 1 && config.capture.lvds_lanes != 2 && config.capture.lvds_lanes != 4)
    fail("capture.lvds_lanes", "1, 2 or 4 lanes, got " + std::to_string(config.capture.lvds_lanes));

  const std::vector<double> gain_re = checked_reals(msg.calibration_gain_re(), "calibration.gain_re");
  const std::vector<double> gain_im = checked_reals(msg.calibration_gain_im(), "calibration.gain_im");
  if (gain_re.size() != gain_im.size())
    fail("calibration.gain_im", "as many entries as gain_re (" + std::to_string(gain_re.size()) + "), got " +
                                    std::to_string(gain_im.size()));
  for (std::size_t i = 0; i < gain_re.size(); ++i) config.calibration.gain.emplace_back(gain_re[i], gain_im[i]);
  config.calibration.frequency_offset_hz =
      checked_reals(msg.calibration_frequency_offset_hz(), "calibration.frequency_offset_hz");

  validate(config, kRecordingFile);
  return config;
}

}  // namespace rsrio
