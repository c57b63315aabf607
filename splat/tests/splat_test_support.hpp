// Helpers shared by the splat tests: small grids, random images, scenes and poses, finite differences.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rsrio/splat/gaussian_scene.hpp"
#include "rsrio/splat/grid.hpp"
#include "rsrio/splat/pose.hpp"

namespace rsrio::splat::test {

/// A small grid: 64 range bins of 0.15 m (to 9.6 m), 64 azimuth bins at d = 0.5 (full +-90 deg),
/// 32 Doppler bins of 0.05 m/s, PSF of a 16-element array without window.
inline RadarImageGrid small_grid() {
  RadarImageGrid g;
  g.range_bins = 64;
  g.azimuth_bins = 64;
  g.doppler_bins = 32;
  g.range_bin_m = 0.15;
  g.element_spacing_wavelengths = 0.5;
  g.velocity_bin_mps = 0.05;
  g.range_psf_sigma_bins = 0.6;
  g.azimuth_psf_sigma_sin = 0.376 / (16 * 0.5);
  return g;
}

/// A rows x cols image of values uniform in [lo, hi).
inline Image<double> random_image(std::mt19937_64& rng, int rows, int cols, double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  Image<double> m(rows, cols);
  for (Eigen::Index k = 0; k < m.size(); ++k) m.data()[k] = u(rng);
  return m;
}

inline Eigen::Isometry3d random_pose(std::mt19937_64& rng, double translation, double angle) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector6d d;
  for (int k = 0; k < 3; ++k) d[k] = translation * u(rng);
  for (int k = 3; k < 6; ++k) d[k] = angle * u(rng);
  return se3_exp(d);
}

/// n Gaussians in front of the radar pose (radar frame range [r0, r1], azimuth +-az, elevation
/// +-el), mapped to the world by the pose; random anisotropic scales and rotations, returns (the
/// view returns, if `options` keeps them, zero).
inline GaussianScene random_scene(std::mt19937_64& rng, const Eigen::Isometry3d& radar_T_world, int n,
                                  double r0 = 2.0, double r1 = 8.0, double az_deg = 50, double el_deg = 15,
                                  double s0 = 0.05, double s1 = 0.4, const SceneOptions& options = {}) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  GaussianScene scene(options);
  const Eigen::Isometry3d world_T_radar = radar_T_world.inverse();
  const double deg = std::numbers::pi / 180.0;
  for (int i = 0; i < n; ++i) {
    const double r = r0 + (r1 - r0) * u(rng);
    const double az = (2 * u(rng) - 1) * az_deg * deg;
    const double el = (2 * u(rng) - 1) * el_deg * deg;
    const Eigen::Vector3d p(r * std::cos(el) * std::cos(az), r * std::cos(el) * std::sin(az), r * std::sin(el));
    Eigen::Quaterniond q(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5);
    // Unnormalised on purpose (norm around 0.5 .. 1.5).
    q.coeffs() *= (0.5 + u(rng)) / q.norm();
    const Eigen::Vector3d log_scale(std::log(s0 + (s1 - s0) * u(rng)), std::log(s0 + (s1 - s0) * u(rng)),
                                    std::log(s0 + (s1 - s0) * u(rng)));
    scene.add(world_T_radar * p, q, log_scale, std::log(0.2 + 2.0 * u(rng)));
  }
  return scene;
}

/// Central difference of f at x along one coordinate.
inline double central_difference(const std::function<double(double)>& f, double x, double h) {
  return (f(x + h) - f(x - h)) / (2 * h);
}

/// max |a - b| / max |b| (block-relative error); 0 for two zero blocks.
inline double relative_error(const std::vector<double>& analytic, const std::vector<double>& numeric) {
  double num = 0, den = 0;
  for (std::size_t k = 0; k < analytic.size(); ++k) {
    num = std::max(num, std::abs(analytic[k] - numeric[k]));
    den = std::max(den, std::abs(numeric[k]));
  }
  return den > 0 ? num / den : num;
}

template <typename Derived>
std::vector<double> to_vector(const Eigen::MatrixBase<Derived>& m) {
  std::vector<double> v(static_cast<std::size_t>(m.size()));
  for (Eigen::Index k = 0; k < m.size(); ++k) v[static_cast<std::size_t>(k)] = m(k);
  return v;
}

}  // namespace rsrio::splat::test
