// The real OpenRadar frame (shared/data/openradar/doppler_example_1.npy, 2 TX x 4 RX, 128 loops,
// 128 samples) through the DSP with config/radar/openradar_frame.yaml and the default options.
//
// What the scene holds (looked at first, with numpy: Hann range / Doppler FFTs, sum over the 8
// virtual channels, 64-bin angle FFT):
//   - a strong static reflector at range bin 107 (5.21 m), zero Doppler, 50 dB over the noise
//     floor, near boresight (azimuth about -2 deg);
//   - a moving target at range bin 60 (2.93 m): its strongest Doppler line at +0.59 m/s (bin 71
//     of 128, receding), azimuth about -7 deg, with a second, weaker group of Doppler lines at
//     -0.4 .. -0.9 m/s at about +12 deg (micro-Doppler of the same object, e.g. swinging limbs);
//   - TX-RX leakage in range bins 0-3 (discarded).
// Azimuth signs follow rsrio's convention (array positions count to the radar's left, see
// processor.hpp); the board's mounting in the recording is not published, so "left" assumes it.
#include <catch2/catch_test_macros.hpp>
#include <cmath>
#include <cstdio>
#include <string>

#include "rsrio/common/options.hpp"
#include "rsrio/dsp/npy.hpp"
#include "rsrio/dsp/processor.hpp"

using namespace rsrio;

namespace {

RadarConfig openradar_config() {
  OptionsFile file("config/radar/openradar_frame.yaml");
  OptionsNode root = file.root();
  OptionsNode radar = root.child("radar", true);
  RadarConfig c = load_radar_config(radar);
  root.finish();
  return c;
}

}  // namespace

TEST_CASE("real OpenRadar frame: the moving target and the static reflector are found", "[dsp][openradar]") {
  const RadarConfig c = openradar_config();
  const NpyArray a = read_npy("../shared/data/openradar/doppler_example_1.npy");
  bool patterns = false;
  const AdcCube cube = npy_to_cube(a, c, "doppler_example_1.npy", &patterns);
  CHECK(patterns);  // OpenRadar stores int16 as uint16 bit patterns
  DspProcessor dsp(c);
  const DspResult& res = dsp.process(cube);
  REQUIRE_FALSE(res.points.empty());

  const DspPoint* stat = nullptr;  // strongest point with |v| < 1 bin
  const DspPoint* mov = nullptr;   // strongest point with |v| > 2 bins
  const double vb = dsp.grids().velocity_bin_mps;
  for (const DspPoint& p : res.points) {
    std::printf("point R %6.3f m  az %6.1f deg  v %+6.3f m/s  snr %5.1f dB\n", p.range_m, p.azimuth_deg,
                p.doppler_mps, p.snr_db);
    if (std::fabs(p.doppler_mps) < vb && (!stat || p.power > stat->power)) stat = &p;
    if (std::fabs(p.doppler_mps) > 2 * vb && (!mov || p.power > mov->power)) mov = &p;
  }
  REQUIRE(stat);
  REQUIRE(mov);
  std::printf("static reflector: R %.3f m, az %.1f deg, v %+.3f m/s, SNR %.1f dB\n", stat->range_m,
              stat->azimuth_deg, stat->doppler_mps, stat->snr_db);
  std::printf("moving target:    R %.3f m, az %.1f deg, v %+.3f m/s, SNR %.1f dB\n", mov->range_m,
              mov->azimuth_deg, mov->doppler_mps, mov->snr_db);
  // the strong static reflector: 5.21 m, near boresight
  CHECK(std::fabs(stat->range_m - 5.21) < 0.1);
  CHECK(std::fabs(stat->azimuth_deg + 2.0) < 5.0);
  CHECK(stat->snr_db > 30);
  // the moving target: 2.93 m, receding at 0.59 m/s, a little to the right
  CHECK(std::fabs(mov->range_m - 2.93) < 0.1);
  CHECK(std::fabs(mov->doppler_mps - 0.59) < 0.1);
  CHECK(std::fabs(mov->azimuth_deg + 7.0) < 5.0);
  CHECK(mov->snr_db > 30);
  // Its approaching micro-Doppler group is detected too.
  bool approaching = false;
  for (const DspPoint& p : res.points)
    if (std::fabs(p.range_m - 2.95) < 0.15 && p.doppler_mps < -0.3 && p.doppler_mps > -1.0)
      approaching = true;
  CHECK(approaching);
  // No elevation from this array (both TX on the lowest row).
  CHECK_FALSE(dsp.grids().has_elevation);
}

TEST_CASE("real OpenRadar frame: range spectrum orientation (leakage at the near bins)", "[dsp][openradar]") {
  const RadarConfig c = openradar_config();
  DspOptions o;
  o.dc_removal = false;
  DspProcessor dsp(c, o);
  const AdcCube cube = npy_to_cube(read_npy("../shared/data/openradar/doppler_example_1.npy"), c);
  const DspResult& res = dsp.process(cube);
  const int Nr = dsp.grids().range_bins, Nd = dsp.grids().doppler_bins;
  auto zero_doppler = [&](int r) { return res.rd[static_cast<std::size_t>(r) * Nd + Nd / 2]; };
  // The TX-RX leakage sits at the first range bins (positive beat frequency), not at the last:
  // the data is used as it is, no conjugation (a mirrored spectrum would swap these).
  CHECK(zero_doppler(1) > 30 * zero_doppler(Nr - 2));
  CHECK(zero_doppler(107) > 100 * zero_doppler(Nr - 107));
}
