// PeakInterpolator: single tones through a plain DFT of the DSP's windows come out where they are
// (to 1e-4 bins), where the plain three-bin Gaussian fit is off by up to a few hundredths.
#include "rsrio/dsp/peak_interpolation.hpp"

#include <algorithm>
#include <catch2/catch_test_macros.hpp>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/window.hpp"

using namespace rsrio;

namespace {

// Powers of bins k - 1, k, k + 1 of the DFT (size n_fft) of taps[i] exp(j (2 pi f p_i / n_fft + phase)).
struct ThreeBins {
  double left, centre, right;
};
ThreeBins tone(const std::vector<double>& taps, const std::vector<int>& positions, int n_fft, double f, double phase,
               int k) {
  double p[3];
  for (int m = -1; m <= 1; ++m) {
    std::complex<double> acc{};
    for (std::size_t i = 0; i < taps.size(); ++i)
      acc += taps[i] * std::polar(1.0, 2 * std::numbers::pi * (f - (k + m)) * positions[i] / n_fft + phase);
    p[m + 1] = std::norm(acc);
  }
  return {p[0], p[1], p[2]};
}

std::vector<int> iota_positions(std::size_t n) {
  std::vector<int> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<int>(i);
  return p;
}

struct Case {
  std::string name;
  std::vector<double> taps;
  std::vector<int> positions;
  int n_fft;
};

// The transforms the DSP interpolates on: its Doppler and range windows (the presets' loops and
// samples, unpadded) and the cascade's and the xwr1843's filled azimuth apertures (zero padded).
std::vector<Case> dsp_cases() {
  std::vector<Case> cases;
  for (const char* w : {"hann", "hamming", "blackman"})
    for (int n : {16, 32, 128}) cases.push_back({std::string(w) + " " + std::to_string(n), make_window(w, n), iota_positions(n), n});
  for (const char* preset : {"mmwcas", "xwr1843"}) {
    const RadarConfig c = radar_preset(preset);
    const RadarDerived d = derive(c);
    int min_el = 1 << 30;
    for (const auto& vc : d.virtual_channels) min_el = std::min(min_el, vc.elevation);
    std::vector<int> positions;
    for (const auto& vc : d.virtual_channels)
      if (vc.elevation == min_el && std::find(positions.begin(), positions.end(), vc.azimuth) == positions.end())
        positions.push_back(vc.azimuth);
    int lo = 1 << 30;
    for (int p : positions) lo = std::min(lo, p);
    for (int& p : positions) p -= lo;
    cases.push_back({std::string(preset) + " aperture", std::vector<double>(positions.size(), 1.0), positions,
                     c.angle_fft_size});
  }
  return cases;
}

}  // namespace

TEST_CASE("PeakInterpolator: a single tone comes out where it is, under every window of the DSP",
          "[dsp][interpolation]") {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> phase(0, 2 * std::numbers::pi);
  for (const Case& c : dsp_cases()) {
    INFO(c.name);
    const PeakInterpolator calibrated(c.taps, c.positions, c.n_fft);
    const PeakInterpolator plain;
    REQUIRE(calibrated.calibrated());
    double worst = 0, worst_plain = 0;
    std::uniform_real_distribution<double> within(calibrated.table_low(), calibrated.table_high());
    std::printf("%-18s table %+.4f .. %+.4f bins\n", c.name.c_str(), calibrated.table_low(), calibrated.table_high());
    CHECK(calibrated.table_low() <= -0.45);
    CHECK(calibrated.table_high() >= 0.45);
    for (int i = 0; i < 400; ++i) {
      const double delta = i == 0 ? 0.0 : within(rng);
      const int k = 5;
      const ThreeBins b = tone(c.taps, c.positions, c.n_fft, k + delta, phase(rng), k);
      worst = std::max(worst, std::abs(calibrated.offset(float(b.left), float(b.centre), float(b.right)) - delta));
      worst_plain = std::max(worst_plain, std::abs(plain.offset(float(b.left), float(b.centre), float(b.right)) - delta));
    }
    std::printf("%-18s worst offset error: calibrated %.2e bins, Gaussian fit %.2e bins\n", c.name.c_str(), worst,
                worst_plain);
    CHECK(worst < 1e-4);
    CHECK(worst_plain > 10 * worst);  // the bias that the calibration takes out is there
  }
}

TEST_CASE("PeakInterpolator: where no three-bin fit exists it is the plain fit", "[dsp][interpolation]") {
  // 120 elements in 128 bins: the first null 1.07 bins out, so a tone 0.1 bins off its bin already
  // has its far neighbour beyond it.
  const std::vector<double> rect(120, 1.0);
  const PeakInterpolator narrow(rect, 128);
  CHECK_FALSE(narrow.calibrated());
  const PeakInterpolator plain;
  CHECK(narrow.offset(1.0f, 4.0f, 2.0f) == plain.offset(1.0f, 4.0f, 2.0f));
  // The same aperture in twice the bins is calibrated.
  CHECK(PeakInterpolator(rect, 256).calibrated());
}

TEST_CASE("PeakInterpolator: what is not a peak gives no offset, bad arguments throw", "[dsp][interpolation]") {
  const PeakInterpolator hann(make_window("hann", 32), 32);
  CHECK(hann.offset(5.0f, 4.0f, 1.0f) == 0.0f);  // the centre is not the maximum
  CHECK(hann.offset(0.0f, 4.0f, 1.0f) == 0.0f);  // a zero power
  CHECK(hann.offset(1.0f, std::nanf(""), 1.0f) == 0.0f);
  CHECK(hann.offset(2.0f, 4.0f, 2.0f) == 0.0f);  // symmetric: on the bin
  CHECK(hann.offset(1.0f, 4.0f, 4.0f) == 0.5f);  // between two bins
  CHECK(std::isnan(gaussian_fit(1, 1, 2)));
  const std::vector<double> taps{1, 1};
  const std::vector<int> one{0}, outside{0, 8};
  CHECK_THROWS_AS(PeakInterpolator(taps, one, 8), std::invalid_argument);
  CHECK_THROWS_AS(PeakInterpolator(taps, outside, 8), std::invalid_argument);
}
