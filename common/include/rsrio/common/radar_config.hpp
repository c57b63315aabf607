// The radar configuration model (SPEC Sec. 4): chirp profile, TDM-MIMO schedule, virtual array
// geometry, capture byte layout and channel calibration, with the quantities derived from them.
//
// One model serves the driver (frame size, byte layout), the simulator (what to synthesise), the
// DSP (FFT sizes, grids) and the estimator (velocity limits). All derived quantities come from
// derive(), so the formulas live in exactly one place.
#pragma once

#include <complex>
#include <cstddef>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

namespace rsrio {

class OptionsNode;

/// Speed of light in vacuum [m/s].
inline constexpr double kSpeedOfLight = 299'792'458.0;

/// The chirp profile as TI's profileCfg describes it.
struct ChirpProfile {
  double start_frequency_ghz = 77.0;
  double slope_mhz_per_us = 29.982;
  double adc_sample_rate_ksps = 5000.0;
  int samples_per_chirp = 256;
  double idle_time_us = 10.0;
  double adc_start_time_us = 6.0;
  double ramp_end_time_us = 60.0;
};

/// Antenna positions in half-wavelengths at the array's design frequency, index = TX id / RX
/// channel in the order the capture hardware delivers them.
struct ArrayGeometry {
  double design_frequency_ghz = 77.0;
  std::vector<int> tx_azimuth;
  std::vector<int> tx_elevation;
  std::vector<int> rx_azimuth;
  std::vector<int> rx_elevation;
};

/// How ADC samples are laid out in the bytes the capture hardware produces.
struct CaptureLayout {
  /// "dca1000": one stream, per chirp RX-blocked samples (xWR16xx/18xx/68xx non-interleaved).
  /// "mmwcas": the cascade's per-device files, [loop][chirp][sample][rx(4)] I/Q interleaved.
  std::string format = "dca1000";
  /// "i_first" (mmWave Studio / DCA1000 CLI default) or "q_first" (SDK demo with sample swap).
  std::string iq_order = "i_first";
  /// "iiqq": groups of two I then two Q (TI 2-lane LVDS); "iq": I/Q pairs interleaved.
  std::string sample_layout = "iiqq";
  /// Offset-binary samples (DCA1000 MSB toggle): flip bit 15 before use.
  bool offset_binary = false;
  int lvds_lanes = 2;
};

/// Per-channel calibration, indexed [tx_id * num_rx + rx]; empty means identity.
struct ChannelCalibration {
  std::vector<std::complex<double>> gain;   // complex gain to multiply the channel by
  std::vector<double> frequency_offset_hz;  // beat-frequency error to remove (cascade)
};

struct RadarConfig {
  std::string preset = "xwr1843";
  ChirpProfile chirp;
  int loops = 64;                  // chirp loops per frame (each loop fires every TX of tx_order once)
  std::vector<int> tx_order;       // TDM slot -> TX id
  double frame_period_ms = 100.0;
  ArrayGeometry array;
  CaptureLayout capture;
  ChannelCalibration calibration;
  int angle_fft_size = 64;         // azimuth FFT (sin-theta bins), zero-padded
};

/// One virtual antenna: (TDM slot, RX channel) and its position in half-wavelengths.
struct VirtualChannel {
  int slot = 0;
  int tx = 0;
  int rx = 0;
  int azimuth = 0;
  int elevation = 0;
};

struct RadarDerived {
  int num_tx = 0;                      // TDM slots per loop
  int num_rx = 0;
  int num_virtual = 0;
  int num_azimuth_unique = 0;          // filled ULA positions at the lowest elevation row
  int range_fft_size = 0;
  int doppler_fft_size = 0;
  double sampling_time_s = 0;          // samples / fs
  double bandwidth_hz = 0;             // sampled bandwidth: slope * sampling time
  double center_frequency_hz = 0;      // start + slope * (adc start + sampling time / 2)
  double wavelength_m = 0;
  double chirp_interval_s = 0;         // idle + ramp end
  double range_resolution_m = 0;       // c / (2 B)
  double range_bin_size_m = 0;         // range resolution * samples / range FFT size
  double max_range_m = 0;              // c fs / (2 slope), complex sampling
  double velocity_resolution_mps = 0;  // lambda / (2 loops num_tx Tc)
  double velocity_bin_size_mps = 0;    // velocity resolution * loops / Doppler FFT size
  double max_velocity_mps = 0;         // lambda / (4 num_tx Tc): unambiguous +-
  double element_spacing_wavelengths = 0;  // 0.5 * fc / f_design
  double azimuth_resolution_deg = 0;   // at boresight: asin(1 / (N_az d))
  double max_azimuth_deg = 0;          // edge of the sin-theta grid
  double frame_active_time_s = 0;      // loops * num_tx * Tc
  std::size_t samples_per_frame = 0;  // complex samples
  std::size_t frame_bytes = 0;         // int16 I and Q
  double data_rate_mbytes_per_s = 0;
  std::vector<VirtualChannel> virtual_channels;  // slot-major, rx-minor
};

/// Names of the built-in presets.
std::vector<std::string_view> radar_presets();
/// A built-in preset; throws std::invalid_argument for an unknown name.
RadarConfig radar_preset(std::string_view name);

/// Everything that follows from the configuration. The configuration must be valid.
RadarDerived derive(const RadarConfig& config);

/// Reads the `radar` section: `preset` first (required), then any key overrides it. Validates the
/// result; throws ConfigError naming the key.
RadarConfig load_radar_config(OptionsNode& node);

/// Physical and structural checks; throws ConfigError(file, key, what) for the first problem.
/// `file` and `section` only label the error.
void validate(const RadarConfig& config, const std::string& file = "<built-in>",
              const std::string& section = "radar");

/// Human-readable dump of the configuration and its derived quantities.
void print(std::ostream& out, const RadarConfig& config);

/// Smallest power of two >= n.
int next_power_of_two(int n);

}  // namespace rsrio
