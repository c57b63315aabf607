#include "rsrio/common/radar_config.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "rsrio/common/options.hpp"

namespace rsrio {

namespace {

// xWR1843BOOST: TX1 and TX3 two wavelengths apart in azimuth, TX2 between them raised by half a
// wavelength; 4 RX half a wavelength apart. TDM order TX1, TX3, TX2 as in TI's SDK demo, so the
// first 8 virtual channels form the filled azimuth array.
RadarConfig preset_xwr1843() {
  RadarConfig c;
  c.preset = "xwr1843";
  c.chirp = ChirpProfile{};  // 77 GHz, 29.982 MHz/us, 5 Msps, 256 samples: 9.8 cm bins to 25 m
  c.loops = 64;
  c.tx_order = {0, 2, 1};
  c.frame_period_ms = 100.0;
  c.array.design_frequency_ghz = 77.0;
  c.array.tx_azimuth = {0, 2, 4};
  c.array.tx_elevation = {0, 1, 0};
  c.array.rx_azimuth = {0, 1, 2, 3};
  c.array.rx_elevation = {0, 0, 0, 0};
  c.capture = CaptureLayout{};  // DCA1000 with TI's tools: I first, IIQQ groups, 2 lanes
  c.angle_fft_size = 64;
  return c;
}

// MMWCAS-RF-EVM: 4 x AWR2243, 12 TX x 16 RX (reference/rio.md Sec. 7.1, TI module_param.m).
// RX channels in capture order: master RX0-3, slave1, slave2, slave3. TDM order TX12..TX1 as TI's
// chain. 10 Hz frames as the MRIO rig runs its cascade.
RadarConfig preset_mmwcas() {
  RadarConfig c;
  c.preset = "mmwcas";
  c.chirp.start_frequency_ghz = 77.0;
  c.chirp.slope_mhz_per_us = 40.0;
  c.chirp.adc_sample_rate_ksps = 5000.0;
  c.chirp.samples_per_chirp = 128;
  c.chirp.idle_time_us = 3.0;
  c.chirp.adc_start_time_us = 6.0;
  c.chirp.ramp_end_time_us = 33.0;
  c.loops = 32;
  c.tx_order = {11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0};
  c.frame_period_ms = 100.0;
  c.array.design_frequency_ghz = 76.8;
  c.array.tx_azimuth = {11, 10, 9, 32, 28, 24, 20, 16, 12, 8, 4, 0};
  c.array.tx_elevation = {6, 4, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  c.array.rx_azimuth = {11, 12, 13, 14, 50, 51, 52, 53, 46, 47, 48, 49, 0, 1, 2, 3};
  c.array.rx_elevation = std::vector<int>(16, 0);
  c.capture.format = "mmwcas";
  c.capture.iq_order = "i_first";
  c.capture.sample_layout = "iq";
  c.capture.offset_binary = false;
  c.capture.lvds_lanes = 4;
  c.angle_fft_size = 128;
  return c;
}

std::string fmt(double v) {
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}

}  // namespace

std::vector<std::string_view> radar_presets() { return {"xwr1843", "mmwcas"}; }

RadarConfig radar_preset(std::string_view name) {
  if (name == "xwr1843") return preset_xwr1843();
  if (name == "mmwcas") return preset_mmwcas();
  throw std::invalid_argument("unknown radar preset '" + std::string(name) + "'");
}

int next_power_of_two(int n) {
  int p = 1;
  while (p < n) p *= 2;
  return p;
}

RadarDerived derive(const RadarConfig& c) {
  RadarDerived d;
  const ChirpProfile& ch = c.chirp;
  const double slope = ch.slope_mhz_per_us * 1e12;  // Hz/s
  const double fs = ch.adc_sample_rate_ksps * 1e3;
  d.num_tx = static_cast<int>(c.tx_order.size());
  d.num_rx = static_cast<int>(c.array.rx_azimuth.size());
  d.num_virtual = d.num_tx * d.num_rx;
  d.range_fft_size = next_power_of_two(ch.samples_per_chirp);
  d.doppler_fft_size = next_power_of_two(c.loops);
  d.sampling_time_s = ch.samples_per_chirp / fs;
  d.bandwidth_hz = slope * d.sampling_time_s;
  d.center_frequency_hz =
      ch.start_frequency_ghz * 1e9 + slope * (ch.adc_start_time_us * 1e-6 + d.sampling_time_s / 2);
  d.wavelength_m = kSpeedOfLight / d.center_frequency_hz;
  d.chirp_interval_s = (ch.idle_time_us + ch.ramp_end_time_us) * 1e-6;
  d.range_resolution_m = kSpeedOfLight / (2 * d.bandwidth_hz);
  d.range_bin_size_m = d.range_resolution_m * ch.samples_per_chirp / d.range_fft_size;
  d.max_range_m = kSpeedOfLight * fs / (2 * slope);
  d.velocity_resolution_mps = d.wavelength_m / (2.0 * c.loops * d.num_tx * d.chirp_interval_s);
  d.velocity_bin_size_mps = d.velocity_resolution_mps * c.loops / d.doppler_fft_size;
  d.max_velocity_mps = d.wavelength_m / (4.0 * d.num_tx * d.chirp_interval_s);
  d.element_spacing_wavelengths = 0.5 * d.center_frequency_hz / (c.array.design_frequency_ghz * 1e9);
  d.frame_active_time_s = c.loops * d.num_tx * d.chirp_interval_s;
  d.samples_per_frame = static_cast<std::size_t>(c.loops) * d.num_virtual * ch.samples_per_chirp;
  d.frame_bytes = d.samples_per_frame * 4;
  d.data_rate_mbytes_per_s = d.frame_bytes / (c.frame_period_ms * 1e-3) / 1e6;

  int min_el = 0;
  bool first = true;
  for (int s = 0; s < d.num_tx; ++s) {
    const int tx = c.tx_order[s];
    for (int r = 0; r < d.num_rx; ++r) {
      VirtualChannel v{s, tx, r, c.array.tx_azimuth[tx] + c.array.rx_azimuth[r],
                       c.array.tx_elevation[tx] + c.array.rx_elevation[r]};
      min_el = first ? v.elevation : std::min(min_el, v.elevation);
      first = false;
      d.virtual_channels.push_back(v);
    }
  }
  std::set<int> azimuths;
  for (const auto& v : d.virtual_channels)
    if (v.elevation == min_el) azimuths.insert(v.azimuth);
  d.num_azimuth_unique = static_cast<int>(azimuths.size());

  const double dsp = d.element_spacing_wavelengths;
  const double rad2deg = 180.0 / std::numbers::pi;
  d.azimuth_resolution_deg = std::asin(std::min(1.0, 1.0 / (d.num_azimuth_unique * dsp))) * rad2deg;
  // sin-theta bins k/(N d), k in [-N/2, N/2): the grid's edge is at (N/2)/(N d) = 1/(2d).
  d.max_azimuth_deg = std::asin(std::min(1.0, 1.0 / (2 * dsp))) * rad2deg;
  return d;
}

void validate(const RadarConfig& c, const std::string& file, const std::string& section) {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(file, section + "." + key, what);
  };
  const ChirpProfile& ch = c.chirp;
  const double f0 = ch.start_frequency_ghz;
  const bool band77 = f0 >= 76.0 && f0 <= 81.0;
  const bool band60 = f0 >= 60.0 && f0 <= 64.0;
  if (!band77 && !band60)
    fail("chirp.start_frequency_ghz", "a start frequency in a TI mmWave band, [60, 64] or [76, 81] GHz, got " + fmt(f0));
  const double band_top = band77 ? 81.0 : 64.0;
  // The sampled part of the sweep must stay in the band. (The ramp itself may run past the band
  // edge after sampling: the real OpenRadar capture ramps to 81.14 GHz and samples to 80.49 GHz.)
  const double sampling_us = ch.samples_per_chirp / (ch.adc_sample_rate_ksps * 1e-3);
  const double f_sampled_end = f0 + ch.slope_mhz_per_us * (ch.adc_start_time_us + sampling_us) * 1e-3;
  if (f_sampled_end > band_top + 1e-9)
    fail("chirp.slope_mhz_per_us", "a sampled sweep inside the band: start + slope x (adc start + samples / rate) = " +
                                       fmt(f_sampled_end) + " GHz exceeds " + fmt(band_top) + " GHz");
  if (ch.adc_start_time_us + sampling_us > ch.ramp_end_time_us + 1e-9)
    fail("chirp.ramp_end_time_us", "a ramp long enough to hold the ADC window: adc start + samples / rate = " +
                                       fmt(ch.adc_start_time_us + sampling_us) + " us > ramp end " +
                                       fmt(ch.ramp_end_time_us) + " us");
  const std::size_t ntx_ant = c.array.tx_azimuth.size();
  if (ntx_ant == 0) fail("array.tx_azimuth", "at least one TX antenna position");
  if (c.array.tx_elevation.size() != ntx_ant)
    fail("array.tx_elevation", "as many entries as array.tx_azimuth (" + std::to_string(ntx_ant) + ")");
  const std::size_t nrx = c.array.rx_azimuth.size();
  if (nrx == 0) fail("array.rx_azimuth", "at least one RX antenna position");
  if (c.array.rx_elevation.size() != nrx)
    fail("array.rx_elevation", "as many entries as array.rx_azimuth (" + std::to_string(nrx) + ")");
  if (c.tx_order.empty()) fail("tx_order", "at least one TDM slot");
  std::set<int> seen;
  for (int tx : c.tx_order) {
    if (tx < 0 || static_cast<std::size_t>(tx) >= ntx_ant)
      fail("tx_order", "TX ids in [0, " + std::to_string(ntx_ant - 1) + "] (array.tx_azimuth has " +
                           std::to_string(ntx_ant) + " TX), got " + std::to_string(tx));
    if (!seen.insert(tx).second) fail("tx_order", "each TX at most once per loop, TX " + std::to_string(tx) + " repeats");
  }
  const double active_ms = c.loops * c.tx_order.size() * (ch.idle_time_us + ch.ramp_end_time_us) * 1e-3;
  if (active_ms > c.frame_period_ms)
    fail("frame_period_ms", "a frame period longer than the chirps of one frame (" + fmt(active_ms) + " ms), got " +
                                fmt(c.frame_period_ms));
  if (c.capture.format == "dca1000" && c.capture.sample_layout == "iiqq" && ch.samples_per_chirp % 2 != 0)
    fail("chirp.samples_per_chirp", "an even number of samples for the IIQQ layout");
  if (c.capture.format == "mmwcas" && (nrx != 16 || ntx_ant != 12))
    fail("capture.format", "mmwcas with 12 TX and 16 RX positions in array (got " + std::to_string(ntx_ant) +
                               " TX, " + std::to_string(nrx) + " RX)");
  const RadarDerived d = derive(c);
  if ((c.angle_fft_size & (c.angle_fft_size - 1)) != 0 || c.angle_fft_size < d.num_azimuth_unique)
    fail("angle_fft_size", "a power of two >= the " + std::to_string(d.num_azimuth_unique) +
                               " unique azimuth elements, got " + std::to_string(c.angle_fft_size));
  const std::size_t nchan = ntx_ant * nrx;
  if (!c.calibration.gain.empty() && c.calibration.gain.size() != nchan)
    fail("calibration.gain_re", std::to_string(nchan) + " entries (TX antennas x RX), got " +
                                     std::to_string(c.calibration.gain.size()));
  if (!c.calibration.frequency_offset_hz.empty() && c.calibration.frequency_offset_hz.size() != nchan)
    fail("calibration.frequency_offset_hz", std::to_string(nchan) + " entries (TX antennas x RX), got " +
                                                std::to_string(c.calibration.frequency_offset_hz.size()));
}

RadarConfig load_radar_config(OptionsNode& node) {
  std::string preset;
  std::string choices;
  node.require("preset", preset);
  RadarConfig c;
  try {
    c = radar_preset(preset);
  } catch (const std::invalid_argument&) {
    node.fail("preset", "one of 'xwr1843' 'mmwcas', got '" + preset + "'");
  }

  OptionsNode ch = node.child("chirp");
  ch.read("start_frequency_ghz", c.chirp.start_frequency_ghz, {1.0, 300.0});
  ch.read("slope_mhz_per_us", c.chirp.slope_mhz_per_us, {1.0, 300.0});
  ch.read("adc_sample_rate_ksps", c.chirp.adc_sample_rate_ksps, {100.0, 50000.0});
  ch.read("samples_per_chirp", c.chirp.samples_per_chirp, {16, 4096});
  ch.read("idle_time_us", c.chirp.idle_time_us, {2.0, 5000.0});
  ch.read("adc_start_time_us", c.chirp.adc_start_time_us, {0.0, 1000.0});
  ch.read("ramp_end_time_us", c.chirp.ramp_end_time_us, {1.0, 5000.0});
  ch.finish();

  node.read("loops", c.loops, {1, 1024});
  node.read("tx_order", c.tx_order, {0, 63});
  node.read("frame_period_ms", c.frame_period_ms, {1.0, 10000.0});
  node.read("angle_fft_size", c.angle_fft_size, {2, 4096});

  OptionsNode arr = node.child("array");
  arr.read("design_frequency_ghz", c.array.design_frequency_ghz, {1.0, 300.0});
  arr.read("tx_azimuth", c.array.tx_azimuth, {-1000, 1000});
  arr.read("tx_elevation", c.array.tx_elevation, {-1000, 1000});
  arr.read("rx_azimuth", c.array.rx_azimuth, {-1000, 1000});
  arr.read("rx_elevation", c.array.rx_elevation, {-1000, 1000});
  arr.finish();

  OptionsNode cap = node.child("capture");
  cap.read_choice("format", c.capture.format, {"dca1000", "mmwcas"});
  cap.read_choice("iq_order", c.capture.iq_order, {"i_first", "q_first"});
  cap.read_choice("sample_layout", c.capture.sample_layout, {"iiqq", "iq"});
  cap.read("offset_binary", c.capture.offset_binary);
  cap.read("lvds_lanes", c.capture.lvds_lanes, {1, 4});
  if (cap.has("lvds_lanes") && c.capture.lvds_lanes == 3) cap.fail("lvds_lanes", "1, 2 or 4 lanes, got 3");
  cap.finish();

  OptionsNode cal = node.child("calibration");
  std::vector<double> re, im;
  cal.read("gain_re", re);
  cal.read("gain_im", im);
  if (re.size() != im.size())
    cal.fail("gain_im", "as many entries as gain_re (" + std::to_string(re.size()) + ")");
  c.calibration.gain.clear();
  for (std::size_t i = 0; i < re.size(); ++i) c.calibration.gain.emplace_back(re[i], im[i]);
  cal.read("frequency_offset_hz", c.calibration.frequency_offset_hz);
  cal.finish();

  node.finish();
  validate(c, node.file(), node.key_path("").substr(0, node.key_path("").size() - 1));
  return c;
}

void print(std::ostream& out, const RadarConfig& c) {
  const RadarDerived d = derive(c);
  auto list = [](const auto& v) {
    std::ostringstream s;
    s << "[";
    for (std::size_t i = 0; i < v.size(); ++i) s << (i ? ", " : "") << v[i];
    s << "]";
    return s.str();
  };
  out << std::setprecision(6);
  out << "radar:\n"
      << "  preset: " << c.preset << "\n"
      << "  chirp:\n"
      << "    start_frequency_ghz: " << c.chirp.start_frequency_ghz << "\n"
      << "    slope_mhz_per_us: " << c.chirp.slope_mhz_per_us << "\n"
      << "    adc_sample_rate_ksps: " << c.chirp.adc_sample_rate_ksps << "\n"
      << "    samples_per_chirp: " << c.chirp.samples_per_chirp << "\n"
      << "    idle_time_us: " << c.chirp.idle_time_us << "\n"
      << "    adc_start_time_us: " << c.chirp.adc_start_time_us << "\n"
      << "    ramp_end_time_us: " << c.chirp.ramp_end_time_us << "\n"
      << "  loops: " << c.loops << "\n"
      << "  tx_order: " << list(c.tx_order) << "\n"
      << "  frame_period_ms: " << c.frame_period_ms << "\n"
      << "  angle_fft_size: " << c.angle_fft_size << "\n"
      << "  array:\n"
      << "    design_frequency_ghz: " << c.array.design_frequency_ghz << "\n"
      << "    tx_azimuth: " << list(c.array.tx_azimuth) << "\n"
      << "    tx_elevation: " << list(c.array.tx_elevation) << "\n"
      << "    rx_azimuth: " << list(c.array.rx_azimuth) << "\n"
      << "    rx_elevation: " << list(c.array.rx_elevation) << "\n"
      << "  capture:\n"
      << "    format: " << c.capture.format << "\n"
      << "    iq_order: " << c.capture.iq_order << "\n"
      << "    sample_layout: " << c.capture.sample_layout << "\n"
      << "    offset_binary: " << (c.capture.offset_binary ? "true" : "false") << "\n"
      << "    lvds_lanes: " << c.capture.lvds_lanes << "\n"
      << "  calibration: " << (c.calibration.gain.empty() ? "identity gain" : std::to_string(c.calibration.gain.size()) + " channel gains")
      << ", " << (c.calibration.frequency_offset_hz.empty() ? "no frequency correction" : "frequency correction") << "\n";
  out << "derived:\n"
      << "  virtual_channels: " << d.num_virtual << " (" << d.num_tx << " TX slots x " << d.num_rx << " RX), "
      << d.num_azimuth_unique << " unique azimuth elements\n"
      << "  center_frequency_ghz: " << d.center_frequency_hz * 1e-9 << "\n"
      << "  wavelength_mm: " << d.wavelength_m * 1e3 << "\n"
      << "  sampled_bandwidth_mhz: " << d.bandwidth_hz * 1e-6 << "\n"
      << "  range_resolution_m: " << d.range_resolution_m << "\n"
      << "  range_bin_size_m: " << d.range_bin_size_m << " (range FFT " << d.range_fft_size << ")\n"
      << "  max_range_m: " << d.max_range_m << "\n"
      << "  chirp_interval_us: " << d.chirp_interval_s * 1e6 << "\n"
      << "  velocity_resolution_mps: " << d.velocity_resolution_mps << "\n"
      << "  velocity_bin_size_mps: " << d.velocity_bin_size_mps << " (Doppler FFT " << d.doppler_fft_size << ")\n"
      << "  max_velocity_mps: " << d.max_velocity_mps << " (unambiguous, +-)\n"
      << "  element_spacing_wavelengths: " << d.element_spacing_wavelengths << "\n"
      << "  azimuth_resolution_deg: " << d.azimuth_resolution_deg << " (boresight)\n"
      << "  azimuth_bins: " << c.angle_fft_size << " sin-theta bins to +-" << d.max_azimuth_deg << " deg\n"
      << "  frame_active_time_ms: " << d.frame_active_time_s * 1e3 << " of " << c.frame_period_ms << " ms\n"
      << "  frame_bytes: " << d.frame_bytes << "\n"
      << "  data_rate_mbytes_per_s: " << d.data_rate_mbytes_per_s << "\n";
}

}  // namespace rsrio
