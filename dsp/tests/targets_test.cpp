// Point targets synthesised with the model of processor.hpp come out where they are: range,
// Doppler velocity and azimuth within half a bin, for both presets, at the edge of the azimuth
// field and near the maximum unambiguous velocity; elevation where the array allows it; TDM
// compensation and channel calibration matter.
#include <algorithm>
#include <catch2/catch_test_macros.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "dsp_test_support.hpp"
#include "rsrio/dsp/processor.hpp"

using namespace rsrio;
using rsrio::test::PointTarget;

namespace {

constexpr double kDeg = std::numbers::pi / 180;

struct Errors {
  double range_bins = 1e9, velocity_bins = 1e9, sin_bins = 1e9;
  const DspPoint* point = nullptr;
};

// The point closest to the target (in bins, velocity wrapped) and its errors in bins.
Errors match(const DspProcessor& dsp, const DspResult& res, const PointTarget& t) {
  const DspGrids& g = dsp.grids();
  const double vmax = g.velocity_bin_mps * g.doppler_bins / 2;
  Errors best;
  double best_score = std::numeric_limits<double>::max();
  for (const DspPoint& p : res.points) {
    Errors e;
    e.range_bins = std::fabs(p.range_m - t.range_m) / g.range_bin_m;
    e.velocity_bins =
        std::fabs(rsrio::test::wrap_velocity(p.doppler_mps - t.velocity_mps, vmax)) / g.velocity_bin_mps;
    const double uy_true = std::cos(t.elevation_deg * kDeg) * std::sin(t.azimuth_deg * kDeg);
    const double uy = std::cos(p.elevation_deg * kDeg) * std::sin(p.azimuth_deg * kDeg);
    e.sin_bins = std::fabs(uy - uy_true) / g.azimuth_sin_bin;
    e.point = &p;
    const double score = e.range_bins + e.velocity_bins + e.sin_bins;
    if (score < best_score) {
      best_score = score;
      best = e;
    }
  }
  return best;
}

void expect_found(const std::string& preset, const std::vector<PointTarget>& targets, double noise = 1.0) {
  const RadarConfig c = radar_preset(preset);
  DspProcessor dsp(c);
  const AdcCube cube = rsrio::test::synthesize(c, targets, noise, 5);
  const DspResult& res = dsp.process(cube);
  for (const auto& t : targets) {
    INFO(preset << ": target R " << t.range_m << " m, v " << t.velocity_mps << " m/s, az " << t.azimuth_deg
                << " deg; " << res.points.size() << " points");
    const Errors e = match(dsp, res, t);
    REQUIRE(e.point);
    INFO("found R " << e.point->range_m << " v " << e.point->doppler_mps << " az " << e.point->azimuth_deg
                    << " el " << e.point->elevation_deg << " snr " << e.point->snr_db);
    CHECK(e.range_bins <= 0.5);
    CHECK(e.velocity_bins <= 0.5);
    CHECK(e.sin_bins <= 0.5);
  }
}

}  // namespace

TEST_CASE("xwr1843: targets at the right range, velocity and azimuth", "[dsp][targets]") {
  const RadarDerived d = derive(radar_preset("xwr1843"));
  const double vb = d.velocity_bin_size_mps, vmax = d.max_velocity_mps;
  SECTION("boresight, static") {
    expect_found("xwr1843", {{6.0, 0.0, 0.0}});
  }
  SECTION("left, receding") {
    expect_found("xwr1843", {{3.3, 1.1, 25.0}});
  }
  SECTION("right, approaching") {
    expect_found("xwr1843", {{12.7, -2.3, -40.0}});
  }
  SECTION("edge of the azimuth field, left") {
    expect_found("xwr1843", {{8.2, 0.7, 68.0}});
  }
  SECTION("edge of the azimuth field, right") {
    expect_found("xwr1843", {{9.9, -0.4, -68.0}});
  }
  SECTION("near +v_max") {
    expect_found("xwr1843", {{7.1, vmax - 1.2 * vb, 15.0}});
  }
  SECTION("near -v_max") {
    expect_found("xwr1843", {{4.4, -vmax + 0.3 * vb, -20.0}});
  }
  SECTION("several targets at once") {
    expect_found("xwr1843", {{2.5, 0.5, -10.0}, {10.0, -1.5, 30.0}, {17.3, 2.0, -50.0}, {21.0, 0.0, 5.0}});
  }
}

TEST_CASE("mmwcas: targets at the right range, velocity and azimuth", "[dsp][targets]") {
  const RadarDerived d = derive(radar_preset("mmwcas"));
  const double vb = d.velocity_bin_size_mps, vmax = d.max_velocity_mps;
  SECTION("boresight, static") {
    expect_found("mmwcas", {{5.0, 0.0, 0.0}});
  }
  SECTION("left, receding") {
    expect_found("mmwcas", {{3.1, 0.8, 33.0}});
  }
  SECTION("right, approaching") {
    expect_found("mmwcas", {{11.7, -1.2, -47.0}});
  }
  SECTION("edge of the azimuth field, left") {
    expect_found("mmwcas", {{7.3, 0.3, 70.0}});
  }
  SECTION("edge of the azimuth field, right") {
    expect_found("mmwcas", {{9.0, -0.3, -70.0}});
  }
  SECTION("near +v_max") {
    expect_found("mmwcas", {{6.2, vmax - 1.1 * vb, 12.0}});
  }
  SECTION("near -v_max") {
    expect_found("mmwcas", {{4.6, -vmax + 0.2 * vb, -25.0}});
  }
  SECTION("several targets at once") {
    expect_found("mmwcas", {{2.2, 0.4, -5.0}, {8.0, -1.0, 20.0}, {14.5, 1.5, -35.0}});
  }
}

// Walking past a wall, the returns of one range ring have Dopplers that change with their angle,
// so one range-Doppler detection holds returns a bin apart. With doppler_own_peak each point takes
// its Doppler from its own azimuth's Doppler peak; without it, from the detection's bin.
TEST_CASE("sub-bin range, Doppler and azimuth are unbiased across a bin", "[dsp][targets][interpolation]") {
  // One target stepped through a bin on each axis at once. The calibrated fit follows it to a
  // few thousandths of a bin; the plain Gaussian fit is off by up to 0.02 bins in Doppler, which
  // on a walk at one speed is a speed error (0.4 % on sequence 1: rio/RESULTS.md).
  for (const char* preset : {"xwr1843", "mmwcas"}) {
    const RadarConfig c = radar_preset(preset);
    double worst_calibrated[3] = {}, worst_gaussian[3] = {};
    for (const char* interpolation : {"calibrated", "gaussian"}) {
      DspOptions o;
      o.interpolation = interpolation;
      DspProcessor dsp(c, o);
      const DspGrids& g = dsp.grids();
      double* worst = std::string(interpolation) == "calibrated" ? worst_calibrated : worst_gaussian;
      // One axis at a time: a moving target's range moves during the frame (the DSP measures
      // its middle, the model starts at its beginning), and its TDM phase, compensated at the
      // Doppler bin's centre, shifts the azimuth by up to a few hundredths of a bin.
      for (int axis = 0; axis < 3; ++axis)
        for (int i = 0; i < 10; ++i) {
          const double frac = 0.05 + 0.1 * i;
          PointTarget t;
          t.range_m = (20 + (axis == 0 ? frac : 0.0)) * g.range_bin_m;
          t.velocity_mps = axis == 1 ? (3 + frac) * g.velocity_bin_mps : 0.0;
          t.azimuth_deg = std::asin((5 + (axis == 2 ? frac : 0.0)) * g.azimuth_sin_bin) / kDeg;
          const DspResult& res = dsp.process(rsrio::test::synthesize(c, {t}, 1.0, 11 + i));
          const Errors e = match(dsp, res, t);
          REQUIRE(e.point);
          worst[axis] = std::max(worst[axis], axis == 0 ? e.range_bins : axis == 1 ? e.velocity_bins : e.sin_bins);
        }
    }
    std::printf("%-8s worst error (bins) range / Doppler / azimuth: calibrated %.4f %.4f %.4f, Gaussian fit %.4f %.4f %.4f\n",
                preset, worst_calibrated[0], worst_calibrated[1], worst_calibrated[2], worst_gaussian[0],
                worst_gaussian[1], worst_gaussian[2]);
    INFO(preset);
    CHECK(worst_calibrated[0] < 0.003);
    CHECK(worst_calibrated[1] < 0.003);
    CHECK(worst_calibrated[2] < 0.003);
    CHECK(worst_gaussian[1] > 0.01);  // what the calibration takes out
  }
}

TEST_CASE("interpolation none: points sit on their bins", "[dsp][targets][interpolation]") {
  const RadarConfig c = radar_preset("mmwcas");
  DspOptions o;
  o.interpolation = "none";
  DspProcessor dsp(c, o);
  const DspGrids& g = dsp.grids();
  PointTarget t;  // a third of a bin off each axis's grid
  t.range_m = 20.3 * g.range_bin_m;
  t.velocity_mps = 3.3 * g.velocity_bin_mps;
  t.azimuth_deg = std::asin(5.3 * g.azimuth_sin_bin) / kDeg;
  const DspResult& res = dsp.process(rsrio::test::synthesize(c, {t}, 1.0, 5));
  const Errors e = match(dsp, res, t);
  REQUIRE(e.point);
  REQUIRE_FALSE(res.points.empty());
  for (const auto& p : res.points) {
    CHECK(p.range_bin == std::round(p.range_bin));
    CHECK(p.doppler_bin == std::round(p.doppler_bin));
    CHECK(p.azimuth_bin == std::round(p.azimuth_bin));
  }
  // The nearest bin: a third of a bin off on each axis.
  CHECK(std::fabs(e.range_bins - 0.3) < 0.02);
  CHECK(std::fabs(e.velocity_bins - 0.3) < 0.02);
}

TEST_CASE("two returns of one range ring a Doppler bin apart: doppler_own_peak keeps each its own Doppler",
          "[dsp][targets]") {
  for (const char* preset : {"xwr1843", "mmwcas"}) {
    const RadarConfig c = radar_preset(preset);
    const double vb = derive(c).velocity_bin_size_mps;
    for (const double offset : {0.7, 0.9, 1.3}) {
      // The second return is weaker, so the detection is the first's; both between bins.
      const PointTarget first{6.0, -3.3 * vb, -20.0, 0.0, 1000};
      const PointTarget second{6.0, (-3.3 + offset) * vb, 30.0, 0.0, 800};
      const AdcCube cube = rsrio::test::synthesize(c, {first, second}, 1.0, 7);
      for (const bool own_peak : {true, false}) {
        DspOptions o;
        o.doppler_own_peak = own_peak;
        DspProcessor dsp(c, o);
        const DspResult& res = dsp.process(cube);
        for (const bool is_second : {false, true}) {
          const PointTarget& t = is_second ? second : first;
          INFO(preset << ": offset " << offset << " bins, target at " << t.azimuth_deg << " deg, doppler_own_peak "
                      << own_peak << ", " << res.points.size() << " points from " << res.detections.size()
                      << " detections");
          const Errors e = match(dsp, res, t);
          REQUIRE(e.point);
          // Each return's sidelobes move the other's fits a little (the xwr1843's 8-element
          // array: up to 0.8 azimuth bins).
          CHECK(e.sin_bins <= 1.0);
          if (own_peak)
            CHECK(e.velocity_bins <= 0.15);
          else if (is_second && offset > 0.8)
            CHECK(e.velocity_bins >= 0.5);  // measured at the detection's bin, d - 3
        }
      }
    }
  }
}

TEST_CASE("TDM compensation: a fast target's azimuth is biased without it", "[dsp][targets][tdm]") {
  struct Case {
    std::string preset;
    double v_fraction, azimuth_deg;
  };
  // xwr1843: the second TX's half of the filled array is rotated -> the peak moves by > 1 bin.
  // mmwcas: nine TX slots interleaved over the 86 elements -> the coherent peak loses > 1 dB
  // (and moves by about 0.3 bin).
  for (const Case& k : {Case{"xwr1843", 0.8, 20.0}, Case{"xwr1843", -0.9, -35.0}, Case{"mmwcas", 0.95, 0.0},
                        Case{"mmwcas", -0.95, -20.0}}) {
    const RadarConfig c = radar_preset(k.preset);
    const RadarDerived d = derive(c);
    const PointTarget t{6.0, k.v_fraction * d.max_velocity_mps, k.azimuth_deg};
    const AdcCube cube = rsrio::test::synthesize(c, {t}, 1.0, 9);
    DspOptions on, off;
    off.tdm_compensation = false;
    DspProcessor dsp_on(c, on), dsp_off(c, off);
    const Errors e_on = match(dsp_on, dsp_on.process(cube), t);
    const Errors e_off = match(dsp_off, dsp_off.process(cube), t);
    REQUIRE(e_on.point);
    INFO(k.preset << " v " << t.velocity_mps << " az " << t.azimuth_deg
                  << ": azimuth error with compensation " << e_on.sin_bins << " bins, without "
                  << e_off.sin_bins << " bins; peak " << e_on.point->power << " vs "
                  << (e_off.point ? e_off.point->power : 0));
    CHECK(e_on.sin_bins <= 0.5);
    CHECK(e_on.velocity_bins <= 0.5);
    const bool biased = !e_off.point || e_off.sin_bins > 1.0;
    const bool smeared = e_off.point && e_off.point->power < 0.8 * e_on.point->power;
    if (k.preset == "xwr1843")
      CHECK(biased);
    else
      CHECK(smeared);
  }
}

TEST_CASE("elevation where the array allows it", "[dsp][targets][elevation]") {
  SECTION("xwr1843: the raised TX gives a coarse elevation, sign up") {
    const RadarConfig c = radar_preset("xwr1843");
    DspProcessor dsp(c);
    for (double el : {20.0, -15.0, 0.0}) {
      const PointTarget t{7.0, 0.6, 12.0, el};
      const DspResult& res = dsp.process(rsrio::test::synthesize(c, {t}, 1.0, 4));
      const Errors e = match(dsp, res, t);
      REQUIRE(e.point);
      INFO("true elevation " << el << ", measured " << e.point->elevation_deg << ", azimuth "
                             << e.point->azimuth_deg);
      CHECK(e.point->elevation_measured);
      CHECK(std::fabs(e.point->elevation_deg - el) < 3.0);
      CHECK(std::fabs(e.point->azimuth_deg - 12.0) < 3.0);
      CHECK(e.sin_bins <= 0.5);
      // x forward, y left, z up
      CHECK(std::fabs(e.point->z - 7.0 * std::sin(el * kDeg)) < 0.4);
      CHECK(e.point->y > 0);
      CHECK(e.point->x > 0);
    }
  }
  SECTION("mmwcas: elevated TX rows 1, 4, 6") {
    const RadarConfig c = radar_preset("mmwcas");
    DspProcessor dsp(c);
    for (double el : {10.0, -6.0}) {
      const PointTarget t{5.5, -0.5, -18.0, el};
      const DspResult& res = dsp.process(rsrio::test::synthesize(c, {t}, 1.0, 8));
      const Errors e = match(dsp, res, t);
      REQUIRE(e.point);
      INFO("true elevation " << el << ", measured " << e.point->elevation_deg);
      CHECK(e.point->elevation_measured);
      CHECK(std::fabs(e.point->elevation_deg - el) < 1.5);
      CHECK(e.sin_bins <= 0.5);
    }
  }
  SECTION("an array without elevated channels reports none") {
    RadarConfig c = radar_preset("xwr1843");
    c.tx_order = {0, 2};
    DspProcessor dsp(c);
    CHECK_FALSE(dsp.grids().has_elevation);
    const DspResult& res = dsp.process(rsrio::test::synthesize(c, {{5.0, 0.3, 10.0}}, 1.0, 4));
    REQUIRE_FALSE(res.points.empty());
    for (const auto& p : res.points) {
      CHECK_FALSE(p.elevation_measured);
      CHECK(p.elevation_deg == 0.0f);
    }
  }
}

TEST_CASE("channel calibration undoes gain and beat-frequency errors", "[dsp][targets][calibration]") {
  RadarConfig c = radar_preset("mmwcas");
  const RadarDerived d = derive(c);
  rsrio::test::ChannelErrors hw;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> ph(-std::numbers::pi, std::numbers::pi), amp(0.7, 1.3),
      fo(-60e3, 60e3);
  const std::size_t n = c.array.tx_azimuth.size() * c.array.rx_azimuth.size();
  for (std::size_t i = 0; i < n; ++i) {
    hw.gain.push_back(std::polar(amp(rng), ph(rng)));
    hw.frequency_offset_hz.push_back(fo(rng));
  }
  for (std::size_t i = 0; i < n; ++i) {
    c.calibration.gain.push_back(1.0 / hw.gain[i]);
    c.calibration.frequency_offset_hz.push_back(hw.frequency_offset_hz[i]);
  }
  const PointTarget t{6.5, 0.4, 28.0};
  const AdcCube cube = rsrio::test::synthesize(c, {t}, 1.0, 21, hw);
  DspOptions with, without;
  without.calibration = false;
  DspProcessor a(c, with), b(c, without);
  const DspResult& ra = a.process(cube);
  const Errors ea = match(a, ra, t);
  REQUIRE(ea.point);
  CHECK(ea.sin_bins <= 0.5);
  CHECK(ea.range_bins <= 0.5);
  const double peak_with = ea.point->power;
  const DspResult& rb = b.process(cube);
  // Uncalibrated, the random channel phases scatter the array's energy: the coherent peak is far
  // lower (and usually in the wrong place).
  double peak_without = 0;
  for (const auto& p : rb.points) peak_without = std::max(peak_without, double(p.power));
  INFO("peak with calibration " << peak_with << ", without " << peak_without << ", vbin "
                                << d.velocity_bin_size_mps);
  CHECK(peak_without < 0.3 * peak_with);
}

TEST_CASE("SNR and noise estimate follow the signal and noise powers", "[dsp][targets]") {
  const RadarConfig c = radar_preset("xwr1843");
  const RadarDerived d = derive(c);
  DspProcessor dsp(c);
  // A target on a grid point: per-sample amplitude A, noise power s2 per sample. Coherent gain of
  // the full chain N_s * L * N_az over the noise power with windows: expected SNR is
  // A^2 / s2 * (N_s / ENBW_r) * (L / ENBW_d) * N_az (rectangular angle window).
  const double A = 10.0, s2 = 100.0;
  const double R = 40 * d.range_bin_size_m;
  const double v = 8 * d.velocity_bin_size_mps;
  const PointTarget t{R, v, 0.0, 0.0, A};
  double sum_db = 0;
  int n = 0;
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    const DspResult& res = dsp.process(rsrio::test::synthesize(c, {t}, s2, seed));
    const Errors e = match(dsp, res, t);
    REQUIRE(e.point);
    sum_db += e.point->snr_db;
    ++n;
  }
  auto enbw = [](int N) {  // hann (MATLAB hanning) equivalent noise bandwidth in bins
    double s1 = 0, s2w = 0;
    for (int i = 0; i < N; ++i) {
      const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * (i + 1) / (N + 1));
      s1 += w;
      s2w += w * w;
    }
    return N * s2w / (s1 * s1);
  };
  const double expected = 10 * std::log10(A * A / s2 * (256 / enbw(256)) * (64 / enbw(64)) * 8);
  INFO("mean SNR " << sum_db / n << " dB, expected " << expected << " dB");
  // Carrier phase moves the target slightly off the bin (range-Doppler coupling is absent in the
  // model, but the 4 pi R / lambda term is exact), so allow for estimator spread.
  CHECK(std::fabs(sum_db / n - expected) < 1.5);
}
