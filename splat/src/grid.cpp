#include "rsrio/splat/grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rsrio::splat {

namespace {
// FWHM of a Gaussian = 2 sqrt(2 ln 2) sigma.
constexpr double kFwhmPerSigma = 2.3548200450309493;
}  // namespace

double window_power_fwhm_bins(std::string_view window) {
  // 3-dB main-lobe widths of |W(f)|^2 (F. J. Harris, "On the use of windows...", 1978, Table 1).
  if (window == "none") return 0.886;
  if (window == "hann") return 1.443;
  if (window == "hamming") return 1.300;
  if (window == "blackman") return 1.680;
  throw std::invalid_argument("unknown DSP window '" + std::string(window) +
                              "' (expected none, hann, hamming or blackman)");
}

RadarImageGrid RadarImageGrid::from_config(const RadarConfig& config, std::string_view range_window,
                                           std::string_view angle_window) {
  const RadarDerived derived = derive(config);
  RadarImageGrid grid;
  grid.range_bins = derived.range_fft_size;
  grid.azimuth_bins = config.angle_fft_size;
  grid.doppler_bins = derived.doppler_fft_size;
  grid.range_bin_m = derived.range_bin_size_m;
  grid.element_spacing_wavelengths = derived.element_spacing_wavelengths;
  grid.velocity_bin_mps = derived.velocity_bin_size_mps;
  // Zero padding from samples_per_chirp to the FFT size stretches the lobe in bins.
  const double range_padding =
      static_cast<double>(derived.range_fft_size) / config.chirp.samples_per_chirp;
  grid.range_psf_sigma_bins = window_power_fwhm_bins(range_window) * range_padding / kFwhmPerSigma;
  // The lobe in sin-theta does not depend on the padding: one DFT bin of the un-padded
  // N_unique-element array is 1 / (N_unique d) in sin-theta.
  const int elements = std::max(1, derived.num_azimuth_unique);
  grid.azimuth_psf_sigma_sin = window_power_fwhm_bins(angle_window) /
                               (elements * derived.element_spacing_wavelengths) / kFwhmPerSigma;
  grid.validate();
  return grid;
}

void RadarImageGrid::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("RadarImageGrid: ") + what);
  };
  require(range_bins > 0 && azimuth_bins > 0 && doppler_bins > 0, "bin counts must be positive");
  require(range_bin_m > 0 && std::isfinite(range_bin_m), "range_bin_m must be positive");
  require(element_spacing_wavelengths > 0 && std::isfinite(element_spacing_wavelengths),
          "element_spacing_wavelengths must be positive");
  require(velocity_bin_mps > 0 && std::isfinite(velocity_bin_mps), "velocity_bin_mps must be positive");
  require(range_psf_sigma_bins > 0 && std::isfinite(range_psf_sigma_bins),
          "range_psf_sigma_bins must be positive");
  require(azimuth_psf_sigma_sin > 0 && std::isfinite(azimuth_psf_sigma_sin),
          "azimuth_psf_sigma_sin must be positive");
}

bool RadarImageGrid::azimuth_valid(int a) const {
  return a >= 0 && a < azimuth_bins && std::abs(azimuth_sin(a)) <= 1.0;
}

int RadarImageGrid::first_valid_azimuth() const {
  for (int a = 0; a < azimuth_bins; ++a)
    if (azimuth_valid(a)) return a;
  return azimuth_bins;
}

int RadarImageGrid::last_valid_azimuth() const {
  for (int a = azimuth_bins - 1; a >= 0; --a)
    if (azimuth_valid(a)) return a;
  return -1;
}

}  // namespace rsrio::splat
