// rsrio-dsp-bench: DSP time per frame against the bare fftw3f transforms of the same sizes.
//
// Per radar preset: the median over N frames of DspProcessor::process() (default options: every
// step, CFAR, points) beside the median time of the three batched transforms alone on contiguous
// buffers (range: loops x virtual FFTs of N_r; Doppler: virtual x N_r FFTs of N_d; angle:
// N_r x N_d FFTs of N_a), planned with the same flags. The ratio shows what the rest of the chain
// (windows, transposes, TDM compensation, powers, CFAR, points) costs on top; the goal is <= 1.5.
//
//   rsrio-dsp-bench [--frames N] [--planning estimate|measure]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <numbers>
#include <string>
#include <vector>

#include "rsrio/common/cli.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/fftw.hpp"
#include "rsrio/dsp/processor.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using cf = std::complex<float>;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// Point targets, a static wall of scatterers and noise, on the int16 scale (cheap synthesis: one
// complex exponential recurrence per chirp and target).
rsrio::AdcCube scene(const rsrio::RadarConfig& c, unsigned seed) {
  const rsrio::RadarDerived d = rsrio::derive(c);
  rsrio::AdcCube cube = rsrio::AdcCube::for_config(c);
  std::srand(seed);
  struct T {
    double r, v, s;
  };
  std::vector<T> targets;
  for (int i = 0; i < 12; ++i)
    targets.push_back({1.0 + 0.8 * i, (i % 5 - 2) * 0.3, std::sin(0.4 * i - 2.0) * 0.8});
  const double slope = c.chirp.slope_mhz_per_us * 1e12, fs = c.chirp.adc_sample_rate_ksps * 1e3;
  for (int m = 0; m < c.loops; ++m)
    for (int k = 0; k < d.num_tx; ++k)
      for (int r = 0; r < d.num_rx; ++r) {
        const auto& vc = d.virtual_channels[k * d.num_rx + r];
        for (const T& t : targets) {
          const double range = t.r + t.v * (m * d.num_tx + k) * d.chirp_interval_s;
          const double w = 2 * std::numbers::pi * 2 * slope * range / rsrio::kSpeedOfLight / fs;
          const double ph0 = 4 * std::numbers::pi * range / d.wavelength_m +
                             2 * std::numbers::pi * d.element_spacing_wavelengths * vc.azimuth * t.s;
          const std::complex<double> step = std::polar(1.0, w);
          std::complex<double> z = std::polar(200.0, ph0);
          for (int n = 0; n < c.chirp.samples_per_chirp; ++n) {
            cube.at(m, k, r, n) += cf(static_cast<float>(z.real()), static_cast<float>(z.imag()));
            z *= step;
          }
        }
        for (int n = 0; n < c.chirp.samples_per_chirp; ++n)
          cube.at(m, k, r, n) +=
              cf(static_cast<float>(std::rand() % 41 - 20), static_cast<float>(std::rand() % 41 - 20));
      }
  return cube;
}

struct Row {
  std::string preset;
  std::string sizes;
  double dsp_ms, fft_ms;
  std::size_t points;
};

Row bench(const std::string& preset, int frames, const std::string& planning) {
  const rsrio::RadarConfig c = rsrio::radar_preset(preset);
  const rsrio::RadarDerived d = rsrio::derive(c);
  rsrio::DspOptions o;
  o.fft_planning = planning;
  rsrio::DspProcessor dsp(c, o);
  std::vector<rsrio::AdcCube> cubes;
  for (unsigned s = 0; s < 4; ++s) cubes.push_back(scene(c, s));

  const int L = c.loops, V = d.num_virtual, Nr = d.range_fft_size, Nd = d.doppler_fft_size,
            Na = c.angle_fft_size;
  const unsigned flags = rsrio::fftw_planner_flags(planning);
  rsrio::AlignedBuffer<cf> r_in(static_cast<std::size_t>(L) * V * Nr), r_out(r_in.size());
  rsrio::AlignedBuffer<cf> d_in(static_cast<std::size_t>(V) * Nr * Nd), d_out(d_in.size());
  rsrio::AlignedBuffer<cf> a_in(static_cast<std::size_t>(Nr) * Nd * Na), a_out(a_in.size());
  rsrio::FftPlan pr(Nr, L * V, 1, Nr, r_in.data(), r_out.data(), flags);
  rsrio::FftPlan pd(Nd, V * Nr, 1, Nd, d_in.data(), d_out.data(), flags);
  rsrio::FftPlan pa(Na, Nr * Nd, 1, Na, a_in.data(), a_out.data(), flags);
  for (std::size_t i = 0; i < r_in.size(); ++i) r_in[i] = cf(float(i % 17), float(i % 13));
  for (std::size_t i = 0; i < d_in.size(); ++i) d_in[i] = cf(float(i % 11), float(i % 7));
  for (std::size_t i = 0; i < a_in.size(); ++i) a_in[i] = cf(float(i % 5), float(i % 3));

  std::vector<double> t_dsp, t_fft;
  std::size_t points = 0;
  for (int i = -3; i < frames; ++i) {  // 3 warm-up frames
    const auto t0 = Clock::now();
    const rsrio::DspResult& res = dsp.process(cubes[static_cast<std::size_t>(i + 3) % cubes.size()]);
    const auto t1 = Clock::now();
    pr.execute();
    pd.execute();
    pa.execute();
    const auto t2 = Clock::now();
    if (i >= 0) {
      t_dsp.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      t_fft.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
      points = res.points.size();
    }
  }
  char sizes[128];
  std::snprintf(sizes, sizeof sizes, "%dx%d R%d D%d A%d", L, V, Nr, Nd, Na);
  return {preset, sizes, median(t_dsp), median(t_fft), points};
}

}  // namespace

int main(int argc, char** argv) {
  std::string frames_text = "40", planning = "estimate";
  rsrio::Cli cli("rsrio-dsp-bench",
                 "DSP time per frame against the bare fftw3f transforms of the same sizes.");
  cli.option("--frames", "N", "frames per preset (median over them; default 40)", &frames_text)
      .option("--planning", "MODE", "FFTW planning: estimate (default, as the DSP default) or measure",
              &planning);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  const int frames = std::atoi(frames_text.c_str());
  if (frames < 1) return cli.usage_error("--frames: expected a positive integer");
  if (planning != "estimate" && planning != "measure")
    return cli.usage_error("--planning: expected estimate or measure");
  std::printf("rsrio-dsp-bench: median over %d frames, FFTW %s, 1 thread\n", frames, planning.c_str());
  std::printf("%-8s %-26s %12s %12s %7s %6s %7s\n", "preset", "loops x virt, FFT sizes", "DSP ms/frame",
              "bare FFT ms", "ratio", "goal", "points");
  for (const char* preset : {"xwr1843", "mmwcas"}) {
    const Row r = bench(preset, frames, planning);
    std::printf("%-8s %-26s %12.3f %12.3f %7.2f %6s %7zu\n", r.preset.c_str(), r.sizes.c_str(), r.dsp_ms,
                r.fft_ms, r.dsp_ms / r.fft_ms, r.dsp_ms / r.fft_ms <= 1.5 ? "<=1.5" : "MISS", r.points);
  }
  return 0;
}
