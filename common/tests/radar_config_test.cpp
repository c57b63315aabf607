// Derived radar quantities against values computed by hand (textbook FMCW formulas, evaluated
// independently of this code; the arithmetic is in the comments).
#include "rsrio/common/radar_config.hpp"

#include <catch2/catch_approx.hpp>
#include <catch2/catch_test_macros.hpp>

#include "rsrio/common/options.hpp"

using Catch::Approx;
using rsrio::derive;
using rsrio::radar_preset;

TEST_CASE("xwr1843 preset derives the textbook range and velocity figures", "[radar_config]") {
  const auto c = radar_preset("xwr1843");
  rsrio::validate(c);
  const auto d = derive(c);
  // B = S * N / fs = 29.982e12 Hz/s * 256 / 5e6 Hz = 1.5350784 GHz
  CHECK(d.bandwidth_hz == Approx(1.5350784e9));
  // dR = c / 2B = 299792458 / 3.0701568e9
  CHECK(d.range_resolution_m == Approx(0.0976472791).epsilon(1e-9));
  // Rmax = c fs / 2S = 299792458 * 5e6 / 5.9964e13
  CHECK(d.max_range_m == Approx(24.9977034554).epsilon(1e-9));
  // fc = 77 GHz + S (6 us + 25.6 us) = 77.9474312 GHz; lambda = c / fc
  CHECK(d.center_frequency_hz == Approx(77.9474312e9));
  CHECK(d.wavelength_m == Approx(3.846085155e-3).epsilon(1e-9));
  // Tc = 10 + 60 us; vmax = lambda / (4 * 3 * 70 us); vres = lambda / (2 * 64 * 3 * 70 us)
  CHECK(d.chirp_interval_s == Approx(70e-6));
  CHECK(d.max_velocity_mps == Approx(4.5786728034).epsilon(1e-9));
  CHECK(d.velocity_resolution_mps == Approx(0.1430835251).epsilon(1e-9));
  CHECK(d.range_fft_size == 256);
  CHECK(d.doppler_fft_size == 64);
  CHECK(d.num_virtual == 12);
  // TX1 and TX3 (azimuth 0 and 4) x RX 0..3 fill azimuth 0..7; TX2 is raised.
  CHECK(d.num_azimuth_unique == 8);
  // d = 0.5 fc / 77 GHz
  CHECK(d.element_spacing_wavelengths == Approx(0.5061521506).epsilon(1e-9));
  // 64 loops * 3 TX * 256 samples * 4 RX * 4 bytes
  CHECK(d.frame_bytes == 64u * 3 * 256 * 4 * 4);
}

TEST_CASE("mmwcas preset: 12 x 16 cascade with the 86-element azimuth array", "[radar_config]") {
  const auto c = radar_preset("mmwcas");
  rsrio::validate(c);
  const auto d = derive(c);
  CHECK(d.num_tx == 12);
  CHECK(d.num_rx == 16);
  CHECK(d.num_virtual == 192);
  CHECK(d.num_azimuth_unique == 86);  // TI module_param.m geometry, 9 TX at elevation 0
  // B = 40e12 * 128 / 5e6 = 1.024 GHz; dR = c / 2.048e9; Rmax = c * 5e6 / 8e13
  CHECK(d.range_resolution_m == Approx(0.1463830361).epsilon(1e-9));
  CHECK(d.max_range_m == Approx(18.737028625).epsilon(1e-9));
  // fc = 77e9 + 40e12 * (6 + 12.8) us = 77.752 GHz; Tc = 36 us
  CHECK(d.max_velocity_mps == Approx(2.2313381751).epsilon(1e-9));   // lambda / (4 * 12 * 36 us)
  CHECK(d.velocity_resolution_mps == Approx(0.1394586359).epsilon(1e-9));  // lambda / (2 * 32 * 12 * 36 us)
  CHECK(d.element_spacing_wavelengths == Approx(0.5061979167).epsilon(1e-9));  // 0.5 fc / 76.8 GHz
  CHECK(c.frame_period_ms == 100.0);  // 10 Hz as the MRIO rig
  // Virtual channels are slot-major: slot 0 fires TX id 11 (TX12), at azimuth 0 elevation 0.
  CHECK(d.virtual_channels.front().tx == 11);
  CHECK(d.virtual_channels.front().azimuth == 0 + 11);
  CHECK(d.virtual_channels[16].tx == 10);
}

TEST_CASE("OpenRadar frame parameters match the figures published with the data", "[radar_config]") {
  auto c = radar_preset("xwr1843");
  c.chirp = {77.4201, 60.0, 2500.0, 128, 30.0, 0.0, 62.0};
  c.loops = 128;
  c.tx_order = {0, 2};
  rsrio::validate(c);
  const auto d = derive(c);
  // README: range resolution c fs / (2 S N) = 0.0488 m
  CHECK(d.range_resolution_m == Approx(0.0488).margin(5e-5));
  // README: velocity resolution at the start frequency 0.0823 m/s; ours uses the centre of the
  // sampled sweep (78.956 GHz), which is 2 % higher: lambda / (2 * 128 * 2 * 92 us) = 0.0806078 m/s.
  // Scaled back to the start frequency it is the README's figure (0.08221 m/s; printed 0.0823).
  CHECK(d.velocity_resolution_mps == Approx(0.0806078293).epsilon(1e-8));
  CHECK(d.velocity_resolution_mps * d.center_frequency_hz / 77.4201e9 == Approx(0.0823).epsilon(2e-3));
}

TEST_CASE("validation names the key of a physically impossible chirp", "[radar_config]") {
  auto c = radar_preset("xwr1843");
  c.chirp.ramp_end_time_us = 40.0;  // ADC window needs 6 + 51.2 us
  try {
    rsrio::validate(c, "f.yaml");
    FAIL("expected a ConfigError");
  } catch (const rsrio::ConfigError& e) {
    CHECK(e.key() == "radar.chirp.ramp_end_time_us");
    CHECK(e.file() == "f.yaml");
  }
  c = radar_preset("xwr1843");
  c.tx_order = {0, 0};
  CHECK_THROWS_AS(rsrio::validate(c), rsrio::ConfigError);
  c = radar_preset("xwr1843");
  c.frame_period_ms = 5.0;  // shorter than 64 * 3 * 70 us = 13.44 ms of chirps
  CHECK_THROWS_AS(rsrio::validate(c), rsrio::ConfigError);
  c = radar_preset("mmwcas");
  c.chirp.slope_mhz_per_us = 200;  // sampled sweep ends at 77 + 200e-3 * (6 + 25.6) = 83.3 GHz, out of band
  CHECK_THROWS_AS(rsrio::validate(c), rsrio::ConfigError);
}

TEST_CASE("unknown preset is refused", "[radar_config]") {
  CHECK_THROWS_AS(radar_preset("awr9999"), std::invalid_argument);
}
