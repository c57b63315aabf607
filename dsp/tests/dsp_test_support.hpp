// Test helpers: point targets synthesised with the textbook model written in
// rsrio/dsp/processor.hpp (independent of the simulator), complex Gaussian noise.
#pragma once

#include <complex>
#include <cstdint>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"

namespace rsrio::test {

struct PointTarget {
  double range_m = 5;
  double velocity_mps = 0;   // > 0 receding
  double azimuth_deg = 0;    // > 0 left
  double elevation_deg = 0;  // > 0 up
  double amplitude = 1000;   // per sample and channel, ADC units
};

/// Hardware imperfections to synthesise, indexed like RadarConfig::calibration ([tx id * N_rx + rx]):
/// the channel is multiplied by gain and its beat frequency raised by frequency_offset_hz.
struct ChannelErrors {
  std::vector<std::complex<double>> gain;
  std::vector<double> frequency_offset_hz;
};

/// One frame: sum of the targets (model of processor.hpp) plus complex white Gaussian noise with
/// E|w|^2 = noise_power.
AdcCube synthesize(const RadarConfig& config, const std::vector<PointTarget>& targets, double noise_power,
                   std::uint32_t seed, const ChannelErrors& errors = {});

/// Wraps a velocity into [-v_max, v_max) of the Doppler grid.
double wrap_velocity(double v, double v_max);

}  // namespace rsrio::test
