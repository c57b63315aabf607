// The differentiable range-Doppler (RD) renderer of RadarSplat++ (paper Sec. III-D, "Proposed
// Differentiable Range-Doppler Rendering"): the RA image is soft-binned into Doppler bins by the
// Doppler each azimuth bin would show for a static world,
//
//   RD[r][j] = gain * sum_a Phi(theta_a) RA[r][a] exp(-(v_D(a) - v_j)^2 / (2 sigma^2)),
//   v_D(a)   = -(v_x cos theta_a + v_y sin theta_a)          (POSITIVE = RECEDING, grid.hpp)
//
// for the radar velocity v in the radar frame (x forward, y left). Sign: a radar moving forward
// (v_x > 0) closes in on static points ahead, which therefore approach: v_D(boresight) = -v_x < 0.
// (The paper writes v_x cos + v_y sin for the scene's velocity relative to the radar; this is the
// same quantity in the DSP's receding-positive convention, SPEC Sec. 8.) Without pixel
// directions, pixels are taken at elevation 0, so v_z does not enter, or (elevation_sigma_sin)
// spread over the elevation beam: RD[r][j] = sum_q w_q sum_a ... with the Doppler of a return
// at elevation el_q, -(v_x sqrt(cos^2 el_q - sin^2 theta_a) + v_y sin theta_a + v_z sin el_q).
// With PixelDirections (grid.hpp; RaRenderer::render_directions: where the map's Gaussians in
// each pixel lie) a pixel's Doppler is the paper's per-Gaussian one, v_D(r, a) = -d(r, a) . v:
// returns above and below the radar close in more slowly than cos(theta_a) says (elevation
// marginalised in the RA image), which at elevation 0 biases the velocity that fits the
// measured RD low (measured on the simulated meeting room: README). The directions are
// constants of render() and backward().
// sigma = kernel_sigma_bins Doppler bins (paper: 3), the kernel is evaluated over +-window_bins
// bins around v_D (paper: 10; cut at 8 sigma, effective_window) and wraps around the Doppler axis
// like the Doppler FFT does. Invalid azimuth bins (|sin| > 1) contribute nothing.
//
// Phi: the DSP's RD is the non-coherent sum over all virtual channels and its RA the
// beamformed power summed over Doppler; by Parseval the sum over azimuth bins of RA equals the
// channel sum up to a constant, and both images already carry the element pattern. Phi = 1
// (kUniform, the default) is therefore the consistent choice with rsrio's DSP; kCosinePower and
// the DART AWR1843 polynomial are available for images that need it.
//
// The renderer keeps per-azimuth kernel tables (no allocation after construction); one instance
// per thread.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "rsrio/splat/grid.hpp"

namespace rsrio::splat {

struct AntennaProfile {
  enum class Kind {
    kUniform,      // Phi = 1
    kCosinePower,  // Phi = cos(theta)^exponent
    kDartAwr1843,  // DART's awr1843boost azimuth pattern, power: 10^(dB / 10),
                   // dB = 0.14 a^6 + 0.13 a^4 - 8.2 a^2, a = theta_deg / 56
  };
  Kind kind = Kind::kUniform;
  double exponent = 2.0;

  /// Power weight for an azimuth bin with sin(theta) = sin_theta (|sin_theta| <= 1).
  double weight(double sin_theta) const;
};

struct RdRenderOptions {
  double kernel_sigma_bins = 3.0;  // soft-binning sigma in Doppler bins
  int window_bins = 10;            // kernel evaluated on +-window_bins around v_D
  AntennaProfile antenna;
  double gain = 1.0;               // RD scale relative to RA
  // The spread of the returns' elevations about the radar's plane, sigma of sin(elevation) (the
  // two-way elevation beam's: sin(beamwidth / (4 sqrt(ln 2))) for a Gaussian beam). 0: every
  // pixel at elevation 0, the paper's model. > 0: each azimuth bin's Doppler is marginalised over
  // three elevations (Gauss-Hermite: sin el = 0, +-sqrt(3) sigma, weights 2/3, 1/6, 1/6), whose
  // returns close in at sqrt(cos^2 el - sin^2 theta) of the forward speed, not cos theta.
  // Without pixel directions only.
  double elevation_sigma_sin = 0.0;
};

/// The kernel's half-width in bins: window_bins, cut at 8 sigma (the kernel is below 1.3e-14 of
/// its peak there; the DSP-lobe sigma of 0.61 bins needs 5 of the paper's 10).
int effective_window(const RdRenderOptions& options);

/// The Doppler (receding positive) of a static point in the direction sin_theta (elevation 0)
/// seen from a radar moving with `velocity` (radar frame).
double static_doppler(const Eigen::Vector3d& velocity, double sin_theta);

template <typename Scalar>
class RdRenderer {
 public:
  explicit RdRenderer(const RadarImageGrid& grid, const RdRenderOptions& options = {});

  const RadarImageGrid& grid() const { return grid_; }
  const RdRenderOptions& options() const { return options_; }

  /// rd (resized to N_r x N_d, overwritten) from an RA image (N_r x N_a) and the velocity;
  /// `directions` (null: elevation 0) must be N_r x N_a (std::invalid_argument otherwise).
  void render(const Image<Scalar>& ra, const Eigen::Vector3d& velocity, Image<Scalar>& rd,
              const PixelDirections<Scalar>* directions = nullptr);

  /// Backward of render(): given dL/dRD, ADDS dL/dRA into grad_ra (resized and zeroed if its
  /// shape is not the RA's) and dL/dv into grad_velocity; either may be null. With directions,
  /// pixels whose RA is exactly 0 get no dL/dRA: nothing is drawn into them, so RaRenderer's
  /// backward never reads them (and their directions are placeholders).
  void backward(const Image<Scalar>& ra, const Eigen::Vector3d& velocity, const Image<Scalar>& grad_rd,
                Image<Scalar>* grad_ra, Eigen::Vector3d* grad_velocity,
                const PixelDirections<Scalar>* directions = nullptr);

 private:
  void prepare(const Eigen::Vector3d& velocity);
  // The kernel taps of one pixel whose Doppler is v_D (m/s): Doppler bins, weights and their
  // derivatives by v_D (when asked), into pixel_index_ / pixel_weight_ / pixel_weight_dv_ (times
  // phi); false (nothing written) for a non-finite or absurd v_D, which then contributes nothing.
  bool pixel_taps(double vd, double phi, bool derivatives);
  void check_directions(const PixelDirections<Scalar>* directions) const;

  RadarImageGrid grid_;
  RdRenderOptions options_;
  int window_ = 0;                   // effective_window(options_)
  int taps_ = 0;                     // 2 window + 1
  int nodes_ = 1;                    // elevation nodes (1: elevation 0)
  int bin_taps_ = 0;                 // nodes_ * taps_: an azimuth bin's taps
  std::vector<double> node_sin_;     // per elevation node: sin(elevation)
  std::vector<double> cos_;          // [azimuth][node] forward part of the direction
  std::vector<double> sin_;          // per azimuth bin
  std::vector<Scalar> phi_;          // gain * Phi, 0 for invalid bins
  std::vector<Scalar> node_phi_;     // [azimuth][node] gain * Phi * node weight (0: no such direction)
  std::vector<int> index_;           // [azimuth][node][tap] Doppler bin (wrapped)
  std::vector<Scalar> weight_;       // [azimuth][node][tap] gain * Phi * node weight * kernel
  std::vector<Scalar> weight_dv_;    // [azimuth][node][tap] d weight / d v_D (per m/s)
  std::vector<char> active_;         // [azimuth][node] contributes
  std::vector<char> bin_active_;     // azimuth bin: any node contributes
  std::vector<double> grad_vd_;      // backward scratch, [azimuth][node]
  double kernel_step_ = 0;           // exp(-1 / sigma^2): the taps' recurrence
  std::vector<int> pixel_index_;     // one pixel's taps (with directions)
  std::vector<Scalar> pixel_weight_, pixel_weight_dv_;
};

extern template class RdRenderer<float>;
extern template class RdRenderer<double>;

}  // namespace rsrio::splat
