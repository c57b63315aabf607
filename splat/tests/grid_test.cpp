#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <cmath>

#include "rsrio/splat/grid.hpp"

using namespace rsrio::splat;
using Catch::Matchers::WithinRel;

TEST_CASE("The grid follows derive() and the DSP's bin conventions", "[splat][grid]") {
  const rsrio::RadarConfig config = rsrio::radar_preset("mmwcas");
  const rsrio::RadarDerived derived = rsrio::derive(config);
  const RadarImageGrid grid = RadarImageGrid::from_config(config);
  CHECK(grid.range_bins == derived.range_fft_size);
  CHECK(grid.azimuth_bins == config.angle_fft_size);
  CHECK(grid.doppler_bins == derived.doppler_fft_size);
  CHECK(grid.range_bin_m == derived.range_bin_size_m);
  CHECK(grid.velocity_bin_mps == derived.velocity_bin_size_mps);
  CHECK(grid.element_spacing_wavelengths == derived.element_spacing_wavelengths);
  // r_k = k dr; u_a = (a - N/2) / (N d); v_j = (j - N/2) dv.
  CHECK(grid.range_m(0) == 0.0);
  CHECK_THAT(grid.range_m(10), WithinRel(10 * derived.range_bin_size_m, 1e-12));
  CHECK(grid.azimuth_sin(grid.azimuth_bins / 2) == 0.0);
  CHECK_THAT(grid.azimuth_sin(grid.azimuth_bins / 2 + 1),
             WithinRel(1.0 / (config.angle_fft_size * derived.element_spacing_wavelengths), 1e-12));
  CHECK(grid.doppler_mps(grid.doppler_bins / 2) == 0.0);
  CHECK(grid.doppler_mps(grid.doppler_bins / 2 - 1) < 0.0);
  CHECK_THAT(grid.sin_to_azimuth_bin(grid.azimuth_sin(17)), WithinRel(17.0, 1e-12));
  CHECK_THAT(grid.velocity_to_doppler_bin(grid.doppler_mps(5)), WithinRel(5.0, 1e-12));
  // PSF: Hann range lobe (no zero padding on the cascade: 128 samples, FFT 128), unwindowed
  // 86-element azimuth lobe.
  CHECK_THAT(grid.range_psf_sigma_bins, WithinRel(1.443 / 2.35482, 1e-4));
  CHECK_THAT(grid.azimuth_psf_sigma_sin,
             WithinRel(0.886 / (derived.num_azimuth_unique * derived.element_spacing_wavelengths) / 2.35482, 1e-4));
}

TEST_CASE("Azimuth bins beyond |sin| = 1 are invalid", "[splat][grid]") {
  RadarImageGrid grid;
  grid.range_bins = 8;
  grid.azimuth_bins = 64;
  grid.doppler_bins = 8;
  grid.range_bin_m = 0.1;
  grid.element_spacing_wavelengths = 0.4;  // grid reaches 1 / (2 d) = 1.25
  grid.velocity_bin_mps = 0.1;
  grid.validate();
  for (int a = 0; a < grid.azimuth_bins; ++a) CHECK(grid.azimuth_valid(a) == (std::abs(grid.azimuth_sin(a)) <= 1.0));
  CHECK(grid.first_valid_azimuth() > 0);
  CHECK(grid.last_valid_azimuth() < grid.azimuth_bins - 1);
  CHECK(std::abs(grid.azimuth_sin(grid.first_valid_azimuth())) <= 1.0);
  CHECK(std::abs(grid.azimuth_sin(grid.first_valid_azimuth() - 1)) > 1.0);
  grid.range_bin_m = 0;
  CHECK_THROWS(grid.validate());
  CHECK_THROWS(window_power_fwhm_bins("kaiser"));
}
