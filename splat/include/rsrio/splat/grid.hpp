// The image grids the renderers draw on, and the image type. These are the CONTRACT between the
// backend and the DSP (dsp/include/rsrio/dsp/processor.hpp, "GRIDS", states the same):
//
//   Radar frame: x forward (boresight), y LEFT, z up.
//   Azimuth theta = atan2(y, x), positive to the LEFT; elevation positive UP.
//
//   range    k = 0..N_r-1  bin centre r_k = k * range_bin_m               (N_r = range FFT size)
//   azimuth  a = 0..N_a-1  sin(theta_a) = u_a = (a - N_a/2) / (N_a * d)   (N_a = angle FFT size,
//                          d = element spacing in wavelengths, N_a/2 integer division). The
//                          coordinate the array measures is the direction cosine u = y / |p|
//                          (= cos(el) sin(az), = sin(theta) at elevation 0); the renderer maps
//                          every point to u. Bins with |u_a| > 1 are invalid: they render 0 and
//                          carry no loss gradient.
//   Doppler  j = 0..N_d-1  v_j = (j - N_d/2) * velocity_bin_mps   POSITIVE = RECEDING (range
//                          increasing). Unambiguous in [-N_d/2, N_d/2) bins; the RD renderer
//                          wraps around like the Doppler FFT.
//   Images: row-major float, RA [range][azimuth], RD [range][doppler] (Image<float> below: rows
//   = range bins).
//
// Point spread: the DSP's main lobes (windowed sinc^2 in power) are modelled as Gaussians, sigma
// in range bins and in sin-theta; from_config() derives them from the DSP windows (see there).
#pragma once

#include <string_view>

#include <Eigen/Core>

#include "rsrio/common/radar_config.hpp"

namespace rsrio::splat {

/// A radar image, rows = range bins, row-major so that Image::data() is [range][column].
template <typename Scalar>
using Image = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Where what an RA pixel shows lies: the unit direction (radar frame) of the Gaussians drawn
/// into it, averaged with their contributions (RaRenderer::render_directions), N_r x N_a each.
/// The RD renderer takes a pixel's Doppler from it: the paper's per-Gaussian v_D = -r^T v, with
/// the elevation that the RA image has marginalised out (a return 30 deg above the radar closes
/// in at cos 30 = 0.87 of the speed of one at elevation 0 with the same sin-theta). Pixels that
/// no Gaussian reaches hold their own direction at elevation 0.
template <typename Scalar>
struct PixelDirections {
  Image<Scalar> x, y, z;
  Image<Scalar> weight;  // the contributions summed (= the rendered RA image)
};

/// Full width at half maximum, in bins of an un-padded DFT, of the main lobe of |DFT|^2 of a
/// window: none 0.886, hann 1.443, hamming 1.300, blackman 1.680. Throws std::invalid_argument for
/// another name.
double window_power_fwhm_bins(std::string_view window);

struct RadarImageGrid {
  int range_bins = 0;     // N_r
  int azimuth_bins = 0;   // N_a
  int doppler_bins = 0;   // N_d
  double range_bin_m = 0;
  double element_spacing_wavelengths = 0;  // d
  double velocity_bin_mps = 0;
  /// Point spread (power) as Gaussian sigmas: in range bins, and in sin-theta.
  double range_psf_sigma_bins = 0.6;
  double azimuth_psf_sigma_sin = 0.01;

  /// The grids of derive(config). PSF: sigma = FWHM / 2.355 of the window's power main lobe,
  /// scaled by the zero padding; range over samples_per_chirp samples zero-padded to the range
  /// FFT (hann: 0.61 bins unpadded), azimuth over the filled azimuth array of N_unique elements
  /// (sin-space FWHM = fwhm_bins / (N_unique d); window "none": sigma = 0.376 / (N_unique d)).
  /// The window names are the DSP's options (dsp.range_window, dsp.angle_window).
  static RadarImageGrid from_config(const RadarConfig& config, std::string_view range_window = "hann",
                                    std::string_view angle_window = "none");

  /// Throws std::invalid_argument when a size or step is not positive.
  void validate() const;

  double range_m(int k) const { return k * range_bin_m; }
  double azimuth_sin_step() const { return 1.0 / (azimuth_bins * element_spacing_wavelengths); }
  double azimuth_sin(int a) const { return (a - azimuth_bins / 2) * azimuth_sin_step(); }
  bool azimuth_valid(int a) const;
  double doppler_mps(int j) const { return (j - doppler_bins / 2) * velocity_bin_mps; }

  /// Continuous bin coordinates (bin k's centre is k).
  double range_to_bin(double range) const { return range / range_bin_m; }
  double sin_to_azimuth_bin(double u) const { return u / azimuth_sin_step() + azimuth_bins / 2; }
  double velocity_to_doppler_bin(double v) const { return v / velocity_bin_mps + doppler_bins / 2; }
  /// The azimuth PSF sigma in azimuth bins.
  double azimuth_psf_sigma_bins() const { return azimuth_psf_sigma_sin / azimuth_sin_step(); }
  /// [first, last] valid azimuth bins (|u| <= 1), the grid is symmetric so they are contiguous.
  int first_valid_azimuth() const;
  int last_valid_azimuth() const;
};

}  // namespace rsrio::splat
