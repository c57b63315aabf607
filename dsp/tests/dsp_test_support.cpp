#include "dsp_test_support.hpp"

#include <cmath>
#include <numbers>
#include <random>

namespace rsrio::test {

AdcCube synthesize(const RadarConfig& config, const std::vector<PointTarget>& targets, double noise_power,
                   std::uint32_t seed, const ChannelErrors& errors) {
  const RadarDerived d = derive(config);
  AdcCube cube = AdcCube::for_config(config);
  const double pi = std::numbers::pi;
  const double slope = config.chirp.slope_mhz_per_us * 1e12;
  const double fs = config.chirp.adc_sample_rate_ksps * 1e3;
  const double lambda = d.wavelength_m;
  const double dsp_d = d.element_spacing_wavelengths;
  const double tc = d.chirp_interval_s;
  const int S = d.num_tx, R = d.num_rx, N = config.chirp.samples_per_chirp;
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, std::sqrt(noise_power / 2));
  for (int m = 0; m < config.loops; ++m)
    for (int k = 0; k < S; ++k)
      for (int r = 0; r < R; ++r) {
        const VirtualChannel& vc = d.virtual_channels[k * R + r];
        const std::size_t idx = static_cast<std::size_t>(vc.tx) * R + vc.rx;
        const std::complex<double> g = errors.gain.empty() ? 1.0 : errors.gain[idx];
        const double foff = errors.frequency_offset_hz.empty() ? 0.0 : errors.frequency_offset_hz[idx];
        const double t = (static_cast<double>(m) * S + k) * tc;
        for (int n = 0; n < N; ++n) {
          std::complex<double> s{};
          for (const auto& tg : targets) {
            const double az = tg.azimuth_deg * pi / 180, el = tg.elevation_deg * pi / 180;
            const double uy = std::cos(el) * std::sin(az), uz = std::sin(el);
            const double range = tg.range_m + tg.velocity_mps * t;
            const double fb = 2 * slope * range / kSpeedOfLight;
            const double phase = 2 * pi * fb * (n - N / 2.0) / fs + 4 * pi * range / lambda -
                                 2 * pi * dsp_d * (vc.azimuth * uy + vc.elevation * uz);
            s += tg.amplitude * std::polar(1.0, phase);
          }
          s *= g * std::polar(1.0, 2 * pi * foff * n / fs);
          if (noise_power > 0) s += std::complex<double>(gauss(rng), gauss(rng));
          cube.at(m, k, r, n) =
              std::complex<float>(static_cast<float>(s.real()), static_cast<float>(s.imag()));
        }
      }
  return cube;
}

double wrap_velocity(double v, double v_max) {
  const double span = 2 * v_max;
  double w = std::fmod(v + v_max, span);
  if (w < 0) w += span;
  return w - v_max;
}

}  // namespace rsrio::test
