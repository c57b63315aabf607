// The fftw3f chain equals a straightforward reference: naive DFT loops in double precision that
// follow the PROCESSING steps of processor.hpp literally (explicit fftshift, explicit zero
// padding, explicit TDM phase, explicit filled array built from derive().virtual_channels).
#include <algorithm>
#include <catch2/catch_test_macros.hpp>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <set>
#include <span>
#include <vector>

#include "dsp_test_support.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/dsp/window.hpp"

using namespace rsrio;
using cd = std::complex<double>;

namespace {

struct Reference {
  int Nr, Nd, Na, V;
  std::vector<cd> chan;  // [v][r][d]
  std::vector<double> rd, rad, ra;
};

std::vector<double> unit_sum(std::vector<double> w) {
  double s = 0;
  for (double x : w) s += x;
  for (double& x : w) x /= s;
  return w;
}

Reference reference(const RadarConfig& c, const DspOptions& o, const AdcCube& cube) {
  const double pi = std::numbers::pi;
  const RadarDerived der = derive(c);
  Reference ref;
  const int L = c.loops, S = der.num_tx, R = der.num_rx, Ns = c.chirp.samples_per_chirp;
  const int Nr = ref.Nr = der.range_fft_size, Nd = ref.Nd = der.doppler_fft_size,
            Na = ref.Na = c.angle_fft_size;
  const int V = ref.V = der.num_virtual;
  const double fs = c.chirp.adc_sample_rate_ksps * 1e3;
  const auto wr = unit_sum(make_window(o.range_window, Ns));
  const auto wd = unit_sum(make_window(o.doppler_window, L));
  ref.chan.assign(static_cast<std::size_t>(V) * Nr * Nd, {});
  for (int v = 0; v < V; ++v) {
    const int k = v / R, rx = v % R;
    const std::size_t idx = static_cast<std::size_t>(c.tx_order[k]) * R + rx;
    const cd g = o.calibration && !c.calibration.gain.empty() ? c.calibration.gain[idx] : cd(1);
    const double f = o.calibration && !c.calibration.frequency_offset_hz.empty()
                         ? c.calibration.frequency_offset_hz[idx]
                         : 0;
    std::vector<cd> X(static_cast<std::size_t>(L) * Nr);
    for (int l = 0; l < L; ++l) {
      cd mean = 0;
      if (o.dc_removal) {
        for (int n = 0; n < Ns; ++n) mean += cd(cube.at(l, k, rx, n));
        mean /= Ns;
      }
      for (int q = 0; q < Nr; ++q) {
        cd s = 0;
        for (int n = 0; n < Ns; ++n)
          s += (cd(cube.at(l, k, rx, n)) - mean) * wr[n] * g * std::polar(1.0, -2 * pi * f * n / fs) *
               std::polar(1.0, -2 * pi * q * n / Nr);
        X[static_cast<std::size_t>(l) * Nr + q] = s;
      }
    }
    if (o.clutter_removal)
      for (int q = 0; q < Nr; ++q) {
        cd m = 0;
        for (int l = 0; l < L; ++l) m += X[static_cast<std::size_t>(l) * Nr + q];
        m /= L;
        for (int l = 0; l < L; ++l) X[static_cast<std::size_t>(l) * Nr + q] -= m;
      }
    for (int q = 0; q < Nr; ++q)
      for (int dd = 0; dd < Nd; ++dd) {
        const int bin = ((dd - Nd / 2) % Nd + Nd) % Nd;  // fftshift
        cd s = 0;
        for (int l = 0; l < L; ++l)
          s += X[static_cast<std::size_t>(l) * Nr + q] * wd[l] * std::polar(1.0, -2 * pi * bin * l / Nd);
        ref.chan[(static_cast<std::size_t>(v) * Nr + q) * Nd + dd] = s;
      }
  }
  ref.rd.assign(static_cast<std::size_t>(Nr) * Nd, 0);
  for (int v = 0; v < V; ++v)
    for (std::size_t i = 0; i < ref.rd.size(); ++i) ref.rd[i] += std::norm(ref.chan[v * ref.rd.size() + i]);

  // filled azimuth array
  int min_el = 1 << 30;
  for (const auto& vc : der.virtual_channels) min_el = std::min(min_el, vc.elevation);
  std::vector<int> pos, chn;
  std::set<int> seen;
  for (int v = 0; v < V; ++v) {
    const auto& vc = der.virtual_channels[v];
    if (vc.elevation == min_el && seen.insert(vc.azimuth).second) {
      pos.push_back(vc.azimuth);
      chn.push_back(v);
    }
  }
  REQUIRE(!pos.empty());
  int pmin = pos[0], pmax = pos[0];
  for (int p : pos) {
    pmin = std::min(pmin, p);
    pmax = std::max(pmax, p);
  }
  const int span = pmax - pmin + 1;
  const auto wa_full = make_window(o.angle_window, span);
  double wa_sum = 0;
  for (int p : pos) wa_sum += wa_full[pmax - p];
  ref.rad.assign(static_cast<std::size_t>(Nr) * Na * Nd, 0);
  ref.ra.assign(static_cast<std::size_t>(Nr) * Na, 0);
  for (int q = 0; q < Nr; ++q)
    for (int dd = 0; dd < Nd; ++dd) {
      std::vector<cd> z(Na, 0.0);
      for (std::size_t i = 0; i < pos.size(); ++i) {
        const int slot = der.virtual_channels[chn[i]].slot;
        const double ph = o.tdm_compensation ? -2 * pi * slot * (dd - Nd / 2) / (double(S) * Nd) : 0;
        // mirrored: the spatial phase falls with the position (positions count to the left)
        z[pmax - pos[i]] = ref.chan[(static_cast<std::size_t>(chn[i]) * Nr + q) * Nd + dd] *
                           std::polar(1.0, ph) * (wa_full[pmax - pos[i]] / wa_sum);
      }
      for (int a = 0; a < Na; ++a) {
        const int bin = ((a - Na / 2) % Na + Na) % Na;
        cd s = 0;
        for (int p = 0; p < Na; ++p) s += z[p] * std::polar(1.0, -2 * pi * bin * p / Na);
        ref.rad[(static_cast<std::size_t>(q) * Nd + dd) * Na + a] = std::norm(s);
        ref.ra[static_cast<std::size_t>(q) * Na + a] += std::norm(s);
      }
    }
  return ref;
}

AdcCube random_cube(const RadarConfig& c, unsigned seed) {
  AdcCube cube = AdcCube::for_config(c);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> u(-2000, 2000);
  for (auto& x : cube.data) x = {float(u(rng)), float(u(rng))};
  return cube;
}

double compare_real(std::span<const float> got, const std::vector<double>& want) {
  REQUIRE(got.size() == want.size());
  double scale = 0, err = 0;
  for (double w : want) scale = std::max(scale, std::fabs(w));
  for (std::size_t i = 0; i < want.size(); ++i) err = std::max(err, std::fabs(got[i] - want[i]));
  return err / scale;
}

double compare_complex(std::span<const std::complex<float>> got, const std::vector<cd>& want) {
  REQUIRE(got.size() == want.size());
  double scale = 0, err = 0;
  for (const cd& w : want) scale = std::max(scale, std::abs(w));
  for (std::size_t i = 0; i < want.size(); ++i) err = std::max(err, std::abs(cd(got[i]) - want[i]));
  return err / scale;
}

void check_against_reference(const RadarConfig& c, const DspOptions& o) {
  DspProcessor dsp(c, o);
  // Two different frames through the same processor: nothing may leak from one into the next.
  for (unsigned seed : {11u, 12u}) {
    const AdcCube cube = random_cube(c, seed);
    const DspResult& res = dsp.process(cube);
    const Reference ref = reference(c, o, cube);
    INFO("frame seed " << seed);
    CHECK(compare_complex(res.channels, ref.chan) < 2e-5);
    CHECK(compare_real(res.rd, ref.rd) < 2e-5);
    CHECK(compare_real(res.rad, ref.rad) < 2e-5);
    CHECK(compare_real(res.ra, ref.ra) < 2e-5);
  }
}

RadarConfig small_xwr1843() {
  RadarConfig c = radar_preset("xwr1843");
  c.chirp.samples_per_chirp = 12;  // zero-padded to 16
  c.loops = 6;                     // zero-padded to 8
  c.angle_fft_size = 16;
  return c;
}

}  // namespace

TEST_CASE("DSP equals a naive DFT reference (xwr1843, zero padding, every option on)", "[dsp][reference]") {
  RadarConfig c = small_xwr1843();
  // Channel calibration: random complex gains and beat-frequency offsets for all 3 x 4 channels.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 12; ++i) {
    c.calibration.gain.emplace_back(1 + 0.3 * u(rng), 0.3 * u(rng));
    c.calibration.frequency_offset_hz.push_back(20e3 * u(rng));
  }
  DspOptions o;
  o.range_window = "hamming";
  o.doppler_window = "hann";
  o.angle_window = "blackman";
  o.dc_removal = true;
  o.clutter_removal = true;
  o.tdm_compensation = true;
  o.cfar.discard_near_bins = 1;
  o.cfar.discard_far_bins = 1;
  o.cfar.train_range = 3;
  o.cfar.train_doppler = 2;
  check_against_reference(c, o);
}

TEST_CASE("DSP equals a naive DFT reference (xwr1843, every option off)", "[dsp][reference]") {
  RadarConfig c = small_xwr1843();
  DspOptions o;
  o.range_window = "none";
  o.doppler_window = "none";
  o.angle_window = "none";
  o.dc_removal = false;
  o.clutter_removal = false;
  o.tdm_compensation = false;
  o.cfar.train_range = 3;
  o.cfar.train_doppler = 2;
  check_against_reference(c, o);
}

TEST_CASE("DSP equals a naive DFT reference (mmwcas geometry, 86-element array)", "[dsp][reference]") {
  RadarConfig c = radar_preset("mmwcas");
  c.chirp.samples_per_chirp = 16;
  c.loops = 8;
  DspOptions o;
  o.fft_planning = "measure";
  o.angle_window = "hann";
  o.cfar.train_range = 3;
  o.cfar.train_doppler = 2;
  o.cfar.guard_doppler = 0;
  o.cfar.discard_near_bins = 1;
  o.cfar.discard_far_bins = 1;
  check_against_reference(c, o);
}

TEST_CASE("the filled azimuth array is the unique lowest-row positions", "[dsp][reference]") {
  DspOptions o;
  {
    DspProcessor dsp(radar_preset("mmwcas"), o);
    CHECK(dsp.grids().azimuth_positions.size() == 86);
    CHECK(dsp.grids().azimuth_positions.front() == 85);  // position 0 -> FFT index 85 (mirrored)
    CHECK(dsp.grids().azimuth_positions.back() == 0);
    CHECK(dsp.grids().has_elevation);
  }
  {
    DspProcessor dsp(radar_preset("xwr1843"), o);
    CHECK(dsp.grids().azimuth_positions == std::vector<int>{7, 6, 5, 4, 3, 2, 1, 0});
    // slots 0 (TX0) and 1 (TX2) fill the array; slot 2 (TX1, raised) gives elevation
    CHECK(dsp.grids().azimuth_channels == std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7});
    CHECK(dsp.grids().has_elevation);
  }
}

TEST_CASE("grids follow the documented formulas", "[dsp][reference]") {
  const RadarConfig c = radar_preset("xwr1843");
  const RadarDerived d = derive(c);
  DspProcessor dsp(c);
  const DspGrids& g = dsp.grids();
  REQUIRE(g.range_bins == 256);
  REQUIRE(g.doppler_bins == 64);
  REQUIRE(g.azimuth_bins == 64);
  CHECK(g.range_m[10] == 10 * d.range_bin_size_m);
  CHECK(g.doppler_mps[32] == 0.0);
  CHECK(g.doppler_mps[0] == -32 * d.velocity_bin_size_mps);
  CHECK(std::fabs(g.doppler_mps[0] + d.max_velocity_mps) < 1e-12);
  CHECK(g.azimuth_sin[32] == 0.0);
  CHECK(std::fabs(g.azimuth_sin[40] - 8.0 / (64 * d.element_spacing_wavelengths)) < 1e-12);
  CHECK(g.azimuth_deg[40] > 0);
}

TEST_CASE("a cube of the wrong shape is refused", "[dsp]") {
  DspOptions o;
  o.cfar.train_doppler = 2;
  DspProcessor dsp(small_xwr1843(), o);
  AdcCube wrong(6, 3, 4, 10);
  CHECK_THROWS_AS(dsp.process(wrong), std::invalid_argument);
}
