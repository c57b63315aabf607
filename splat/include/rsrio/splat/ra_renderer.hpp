// The differentiable range-azimuth (RA) renderer (paper Sec. III-D, reference/renderer.md Sec. 1)
// with a hand-written backward pass.
//
// For a pose radar_T_world (pose.hpp) each Gaussian i is
//   1. moved into the radar frame: p = R mu + t, Sigma_r = R Sigma R^T;
//   2. mapped to polar-grid coordinates x = (range bin, azimuth bin, w) with
//        range bin   = |p| / range_bin_m
//        azimuth bin = u / (1 / (N_a d)) + N_a / 2,   u = p_y / |p|  (the grid's sin-theta, see grid.hpp)
//        w           = p_z / |p|                       (sin of elevation)
//      and the first-order Jacobian J = dx/dp: Sigma_x = J Sigma_r J^T (EWA splatting; with the
//      direction cosines as coordinates J is regular everywhere but at p = 0);
//   3. reduced to (range, azimuth) by marginalising w (RadarSplat's "orthogonal weighted average
//      along elevation"), or, with elevation_gain_sigma_sin = s > 0, weighted by the elevation
//      gain g(w) = exp(-w^2 / (2 s^2)) in closed form: with tau = Sigma_ww + s^2, b = Sigma_aw,
//        mu_a' = mu_a - b mu_w / tau,  Sigma_aa' = Sigma_aa - b b^T / tau,
//        c = s / sqrt(tau) exp(-mu_w^2 / (2 tau));
//   4. convolved with the DSP point spread (grid.hpp): Sigma_2 = Sigma_aa' + diag(sr^2, sa^2),
//      exact for Gaussians;
//   5. drawn as  I[k][a] += A exp(-1/2 d^T Sigma_2^-1 d),  d = (k, a) - mu_a',
//        A = rho * v(phi) * c * (r_ref / |p|)^n * sqrt(det Sigma_psf / det Sigma_2),
//      so a point scatterer peaks at its return ratio rho (energy = rho times the PSF's, for any
//      extent). n = range_falloff_exponent (0 = none, as RadarSplat; 4 = the radar equation's
//      1/R^4 in power). v(phi) = exp(sum_k c_k b_k(phi)) is the Gaussian's view-dependent return
//      (gaussian_scene.hpp) at the horizontal azimuth phi of R^T p, the direction it is seen
//      from in the world frame, when view_dependent_return is on (1 otherwise). Plain sum, no
//      occlusion.
// Pixels are visited only inside the ellipse d^T Sigma_2^-1 d <= cutoff_sigma^2 (within the
// cutoff_sigma box, tighter), clipped to the grid and its valid azimuth bins; the Gaussian is
// evaluated along each row by a multiplicative recurrence (three exp() per row, two
// multiplications per pixel).
//
// Gaussians are skipped (contribute nothing, receive no gradient) when the mean is nearer than
// min_range_m or not in front (p_x <= min_forward_m): a linear array cannot tell front from back
// and the patch antennas look forward.
//
// Scalar: float for speed, double for the finite-difference tests; per-Gaussian set-up is always
// double. render() and backward() are const and allocate nothing: one renderer may serve
// several threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rsrio/splat/gaussian_scene.hpp"
#include "rsrio/splat/grid.hpp"
#include "rsrio/splat/pose.hpp"

namespace rsrio::splat {

struct RaRenderOptions {
  double cutoff_sigma = 3.0;               // Mahalanobis radius of the evaluated footprint
  double elevation_gain_sigma_sin = 0.0;   // <= 0: plain marginal over elevation (RadarSplat)
  double range_falloff_exponent = 0.0;     // amplitude *= (reference / range)^n; 0: none
  double range_falloff_reference_m = 1.0;
  // Two-way azimuth power gain exp(-theta^2 / (2 sigma^2)) at each Gaussian's mean azimuth theta
  // (atan2(y, x) in the radar frame); <= 0: none. The antenna's element pattern is in every
  // measured RA pixel; a map whose returns are one number per Gaussian, seen from all sides,
  // otherwise renders wide-azimuth returns too bright, and the RD rendered from it fits the
  // velocity fast (rsrio-splat-bench: 1.025 x the true speed without, 0.977 with the beam, as the
  // DSP's own RA at 0.978). The shipped scenarios' beam: 36 deg (sim::RadarModelOptions).
  double azimuth_gain_sigma_deg = 0.0;
  // Each Gaussian's return depends on the horizontal direction it is seen from (its view
  // returns, gaussian_scene.hpp); false: one return for every view (the terms are ignored). A
  // wall seen head-on returns much more than seen at grazing incidence; a map whose Gaussians
  // have one return each renders a wall far down a corridor as bright as it was seen across it.
  bool view_dependent_return = false;
  double min_range_m = 0.1;
  double min_forward_m = 0.0;
};

/// What the renderer multiplies the return of a point scatterer (a Gaussian of zero size) at p
/// (radar frame) with, factor by factor, under these options; 1 where an option is off or p is
/// the origin. The backend divides a new Gaussian's measured power by them.
struct PointGains {
  double elevation = 1;  // elevation_gain_sigma_sin
  double azimuth = 1;    // azimuth_gain_sigma_deg
  double falloff = 1;    // range_falloff_exponent
};
PointGains point_gains(const RaRenderOptions& options, const Eigen::Vector3d& p);

/// One Gaussian on the grid (what render() draws).
struct GaussianFootprint {
  bool visible = false;          // passed the range / hemisphere tests and has a finite footprint
  double range_bin = 0;          // mean, continuous bins
  double azimuth_bin = 0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // bins^2, PSF included
  double amplitude = 0;          // peak value
};

struct RenderStats {
  std::size_t gaussians_drawn = 0;  // touched at least one pixel
  std::size_t pixels = 0;           // pixel evaluations
};

template <typename Scalar>
class RaRenderer {
 public:
  explicit RaRenderer(const RadarImageGrid& grid, const RaRenderOptions& options = {});

  const RadarImageGrid& grid() const { return grid_; }
  const RaRenderOptions& options() const { return options_; }

  /// Renders the listed Gaussians (e.g. GaussianScene::query_radius around the radar) into
  /// `image`, which is resized to N_r x N_a and overwritten.
  RenderStats render(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                     std::span<const std::uint32_t> gaussians, Image<Scalar>& image) const;
  /// All Gaussians.
  RenderStats render(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                     Image<Scalar>& image) const;

  /// Backward of render() for the same scene, pose and list: given dL/dI (N_r x N_a), ADDS
  /// dL/d(parameters) into `gradients` (must be sized to the scene, SceneGradients::reset) and,
  /// if grad_pose is not null, dL/d(delta) of the pose's left increment (pose.hpp) into it.
  /// Either output may be null.
  void backward(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                std::span<const std::uint32_t> gaussians, const Image<Scalar>& grad_image,
                SceneGradients* gradients, Vector6d* grad_pose) const;
  void backward(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                const Image<Scalar>& grad_image, SceneGradients* gradients, Vector6d* grad_pose) const;

  /// The directions of what each pixel of render()'s image shows (grid.hpp, PixelDirections):
  /// every Gaussian's unit mean direction in the radar frame, averaged per pixel with its
  /// contribution. Forward only: the stages take them as constants (they move with the poses
  /// and means by far less than a Doppler bin within a stage).
  void render_directions(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                         std::span<const std::uint32_t> gaussians, PixelDirections<Scalar>& directions) const;

  /// Where and how Gaussian i lands on the grid for this pose.
  GaussianFootprint footprint(const GaussianScene& scene, std::size_t i,
                              const Eigen::Isometry3d& radar_T_world) const;

 private:
  // gaussians == nullptr: all.
  template <typename Visit>
  void for_each(const GaussianScene& scene, const std::span<const std::uint32_t>* gaussians, Visit&& visit) const;
  // The forward draw: pixel(projection, index, value) for every pixel (row-major index) that a
  // Gaussian reaches, with its contribution; shared by render and render_directions.
  template <typename Pixel>
  RenderStats draw(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                   const std::span<const std::uint32_t>* gaussians, Pixel&& pixel) const;
  RenderStats render_impl(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                          const std::span<const std::uint32_t>* gaussians, Image<Scalar>& image) const;
  void backward_impl(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                     const std::span<const std::uint32_t>* gaussians, const Image<Scalar>& grad_image,
                     SceneGradients* gradients, Vector6d* grad_pose) const;

  RadarImageGrid grid_;
  RaRenderOptions options_;
  int first_azimuth_ = 0;
  int last_azimuth_ = -1;
};

extern template class RaRenderer<float>;
extern template class RaRenderer<double>;

}  // namespace rsrio::splat
