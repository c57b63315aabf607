#include "rsrio/splat/ra_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace rsrio::splat {

namespace {

// The amplitude factors of RaRenderOptions that depend on the mean alone; project() and
// point_gains() share them.
double inverse_azimuth_variance(const RaRenderOptions& o) {
  if (!(o.azimuth_gain_sigma_deg > 0)) return 0;
  const double sigma = o.azimuth_gain_sigma_deg * std::numbers::pi / 180.0;
  return 1.0 / (sigma * sigma);
}
double azimuth_gain(double theta, double inv_azimuth_var) {
  return inv_azimuth_var > 0 ? std::exp(-0.5 * theta * theta * inv_azimuth_var) : 1.0;
}
double range_falloff(double exponent, double reference_m, double inv_range) {
  return exponent != 0 ? std::pow(reference_m * inv_range, exponent) : 1.0;
}

// Rotation matrix of a unit quaternion (w, x, y, z).
Eigen::Matrix3d quat_to_rotation(const Eigen::Vector4d& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  Eigen::Matrix3d r;
  r << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),  //
      2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),  //
      2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
  return r;
}

// dL/dq (unit quaternion) from dL/dR.
Eigen::Vector4d rotation_to_quat_grad(const Eigen::Vector4d& q, const Eigen::Matrix3d& g) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  Eigen::Vector4d out;
  out[0] = 2 * (-z * g(0, 1) + y * g(0, 2) + z * g(1, 0) - x * g(1, 2) - y * g(2, 0) + x * g(2, 1));
  out[1] = 2 * (y * g(0, 1) + z * g(0, 2) + y * g(1, 0) - 2 * x * g(1, 1) - w * g(1, 2) + z * g(2, 0) +
                w * g(2, 1) - 2 * x * g(2, 2));
  out[2] = 2 * (-2 * y * g(0, 0) + x * g(0, 1) + w * g(0, 2) + x * g(1, 0) + z * g(1, 2) - w * g(2, 0) +
                z * g(2, 1) - 2 * y * g(2, 2));
  out[3] = 2 * (-2 * z * g(0, 0) - w * g(0, 1) + x * g(0, 2) + w * g(1, 0) - 2 * z * g(1, 1) +
                y * g(1, 2) + x * g(2, 0) + y * g(2, 1));
  return out;
}

// (A12 - A21, A20 - A02, A01 - A10): tr(A [e]x) = vee_antisym(A) . e
Eigen::Vector3d vee_antisym(const Eigen::Matrix3d& a) {
  return {a(1, 2) - a(2, 1), a(2, 0) - a(0, 2), a(0, 1) - a(1, 0)};
}

// Constants of the grid and options that the projection needs.
struct Context {
  double inv_range_bin = 0;    // 1 / range_bin_m
  double inv_azimuth_step = 0; // N_a d
  double azimuth_center = 0;   // N_a / 2
  double psf_var_range = 0;    // bins^2
  double psf_var_azimuth = 0;  // bins^2
  double psf_sqrt_det = 0;
  double elevation_var = 0;    // s^2, 0: no elevation gain
  double inv_azimuth_var = 0;  // 1 / sigma_theta^2 (rad^-2), 0: no azimuth gain
  double falloff_exponent = 0;
  double falloff_reference = 1;
  double min_range = 0;
  double min_forward = 0;
  bool view_return = false;
};

// One Gaussian's projection with every intermediate the backward pass needs.
struct Projection {
  bool visible = false;
  // Footprint on the grid.
  double mu_r = 0, mu_a = 0;             // bins
  Eigen::Matrix2d sigma2;                // PSF included
  Eigen::Matrix2d precision;             // sigma2^-1
  double det2 = 0;
  double amplitude = 0;
  // Intermediates.
  Eigen::Vector4d q_unit;
  double q_norm = 0;
  Eigen::Matrix3d rot_q;                 // R(q)
  Eigen::Vector3d scale;
  Eigen::Matrix3d sigma_radar;           // radar-frame covariance
  Eigen::Vector3d p;                     // radar-frame mean
  double range = 0;
  Eigen::Vector3d n;                     // p / |p|
  double u = 0, w = 0;                   // direction cosines y, z
  Eigen::Matrix3d jac;                   // d(range bin, azimuth bin, w) / dp
  Eigen::Matrix3d sigma_pol;
  double tau = 0;                        // Sigma_ww + s^2 (elevation gain)
  double gain = 1;                       // c
  double rho = 0;
  double falloff = 1;
  double theta = 0;                      // atan2(p_y, p_x)
  double azimuth_gain = 1;
  // View-dependent return: d = R^T p (world-frame view direction), phi its horizontal azimuth.
  Eigen::Vector3d view_dir = Eigen::Vector3d::Zero();
  double view_planar2 = 0;               // d_x^2 + d_y^2; 0: seen from straight above, isotropic
  double view_basis[kViewTerms] = {};    // cos phi, sin phi, cos 2 phi, sin 2 phi
  double view_slope = 0;                 // d log v / d phi
  double view = 1;                       // v(phi)
};

// The Fourier basis of the view return at the world-frame view direction d, and v and its slope
// in phi for the coefficients c.
void view_return(const Eigen::Vector3d& d, const double* c, Projection& g) {
  g.view_dir = d;
  g.view_planar2 = d.x() * d.x() + d.y() * d.y();
  g.view = 1;
  g.view_slope = 0;
  std::fill_n(g.view_basis, kViewTerms, 0.0);
  if (!(g.view_planar2 > 1e-18)) return;
  const double inv = 1.0 / std::sqrt(g.view_planar2);
  const double cs = d.x() * inv, sn = d.y() * inv;
  const double cos2 = cs * cs - sn * sn, sin2 = 2 * cs * sn;
  g.view_basis[0] = cs;
  g.view_basis[1] = sn;
  g.view_basis[2] = cos2;
  g.view_basis[3] = sin2;
  double log_v = 0;
  for (std::size_t k = 0; k < kViewTerms; ++k) log_v += c[k] * g.view_basis[k];
  g.view = std::exp(log_v);
  // d basis / d phi = (-sin, cos, -2 sin 2 phi, 2 cos 2 phi).
  g.view_slope = -c[0] * sn + c[1] * cs - 2 * c[2] * sin2 + 2 * c[3] * cos2;
}

void project(const GaussianScene& scene, std::size_t i, const Eigen::Matrix3d& r_tw,
             const Eigen::Vector3d& t_tw, const Context& ctx, Projection& g) {
  g.visible = false;
  const Eigen::Vector3d mean = scene.mean(i);
  g.p = r_tw * mean + t_tw;
  g.range = g.p.norm();
  if (!(g.range >= ctx.min_range) || !(g.p.x() > ctx.min_forward)) return;

  const double* qs = &scene.rotations()[4 * i];
  const Eigen::Vector4d q(qs[0], qs[1], qs[2], qs[3]);
  g.q_norm = q.norm();
  if (!(g.q_norm > 0)) return;
  g.q_unit = q / g.q_norm;
  g.rot_q = quat_to_rotation(g.q_unit);
  const double* ls = &scene.log_scales()[3 * i];
  g.scale = Eigen::Vector3d(std::exp(ls[0]), std::exp(ls[1]), std::exp(ls[2]));
  const Eigen::Matrix3d m = g.rot_q * g.scale.asDiagonal();
  const Eigen::Matrix3d rm = r_tw * m;
  g.sigma_radar = rm * rm.transpose();

  const double inv_r = 1.0 / g.range;
  g.n = g.p * inv_r;
  g.u = g.n.y();
  g.w = g.n.z();
  const Eigen::Vector3d ey = Eigen::Vector3d::UnitY(), ez = Eigen::Vector3d::UnitZ();
  g.jac.row(0) = g.n.transpose() * ctx.inv_range_bin;
  g.jac.row(1) = (ey - g.u * g.n).transpose() * (inv_r * ctx.inv_azimuth_step);
  g.jac.row(2) = (ez - g.w * g.n).transpose() * inv_r;
  g.sigma_pol = g.jac * g.sigma_radar * g.jac.transpose();

  double mu_r = g.range * ctx.inv_range_bin;
  double mu_a = g.u * ctx.inv_azimuth_step + ctx.azimuth_center;
  Eigen::Matrix2d sigma_a = g.sigma_pol.topLeftCorner<2, 2>();
  g.gain = 1.0;
  if (ctx.elevation_var > 0) {
    g.tau = g.sigma_pol(2, 2) + ctx.elevation_var;
    const Eigen::Vector2d b = g.sigma_pol.block<2, 1>(0, 2);
    mu_r -= b[0] * g.w / g.tau;
    mu_a -= b[1] * g.w / g.tau;
    sigma_a -= b * b.transpose() / g.tau;
    g.gain = std::sqrt(ctx.elevation_var / g.tau) * std::exp(-g.w * g.w / (2 * g.tau));
  }
  g.mu_r = mu_r;
  g.mu_a = mu_a;
  g.sigma2 = sigma_a;
  g.sigma2(0, 0) += ctx.psf_var_range;
  g.sigma2(1, 1) += ctx.psf_var_azimuth;
  // Symmetrise: the two off-diagonals come from different rounding.
  g.sigma2(0, 1) = g.sigma2(1, 0) = 0.5 * (g.sigma2(0, 1) + g.sigma2(1, 0));
  g.det2 = g.sigma2(0, 0) * g.sigma2(1, 1) - g.sigma2(0, 1) * g.sigma2(0, 1);
  if (!(g.det2 > 0) || !std::isfinite(g.det2)) return;
  g.precision << g.sigma2(1, 1), -g.sigma2(0, 1), -g.sigma2(0, 1), g.sigma2(0, 0);
  g.precision /= g.det2;

  g.rho = std::exp(scene.log_returns()[i]);
  g.falloff = range_falloff(ctx.falloff_exponent, ctx.falloff_reference, inv_r);
  if (ctx.inv_azimuth_var > 0) g.theta = std::atan2(g.p.y(), g.p.x());
  g.azimuth_gain = azimuth_gain(g.theta, ctx.inv_azimuth_var);
  if (ctx.view_return) {
    view_return(r_tw.transpose() * g.p, &scene.view_returns()[kViewTerms * i], g);
  } else {
    g.view = 1;
  }
  g.amplitude = g.rho * g.view * g.gain * g.falloff * g.azimuth_gain * ctx.psf_sqrt_det / std::sqrt(g.det2);
  g.visible = std::isfinite(g.amplitude) && std::isfinite(mu_r) && std::isfinite(mu_a);
}

// ceil / floor for values well inside the int range: the baseline x86-64 target has no rounding
// instruction, and libm's calls cost more than the rest of a row's set-up.
inline double fast_ceil(double x) {
  const double t = static_cast<double>(static_cast<long long>(x));
  return t < x ? t + 1.0 : t;
}
inline double fast_floor(double x) {
  const double t = static_cast<double>(static_cast<long long>(x));
  return t > x ? t - 1.0 : t;
}

// One row of a footprint to draw: columns [a0, a1] of row k, the Gaussian at a0 and the ratio
// between consecutive columns there (the next ratio is ratio * exp(-p22)).
struct RowSpan {
  int k = 0, a0 = 0, a1 = -1;
  double d1 = 0, d2 = 0;  // offsets of (k, a0) from the mean
  double value = 0;       // exp(-Q/2) at (k, a0)
  double ratio = 0;       // value(k, a0 + 1) / value(k, a0)
};

// Visits the rows of a footprint's ellipse Q = d^T P d <= cutoff^2 on the grid.
//
// The Gaussian is carried from row to row by multiplicative recurrences instead of exp() per row:
// an anchor (k, a) holds E = exp(-Q/2), the column ratio E(k, a+1)/E(k, a) and the row ratio
// E(k+1, a)/E(k, a). Moving the anchor down multiplies E by the row ratio, moving it right by
// the column ratio; the ratios themselves change by the constant factors exp(-p11), exp(-p12),
// exp(-p22). The anchor follows the left edge of the ellipse, so every value it passes is within
// (or one step outside) the ellipse and far from under/overflow; a jump of more than
// kMaxWalk columns between rows (very slanted footprints) re-seeds it with exp(). All in double.
// The PSF bounds the precision (p11 <= 1/sr^2, p22 <= 1/sa^2), so the ratios stay moderate.
// Returns whether any pixel was visited.
template <typename RowFn>
bool walk_rows(const Projection& g, double cutoff, int rows, int first_a, int last_a, RowFn&& fn) {
  constexpr int kMaxWalk = 8;
  const double half_r = cutoff * std::sqrt(g.sigma2(0, 0));
  const double half_a = cutoff * std::sqrt(g.sigma2(1, 1));
  const double lo_r = std::max(0.0, fast_ceil(g.mu_r - half_r));
  const double hi_r = std::min(rows - 1.0, fast_floor(g.mu_r + half_r));
  if (lo_r > hi_r) return false;
  if (g.mu_a + half_a < first_a || g.mu_a - half_a > last_a) return false;
  const int k0 = static_cast<int>(lo_r), k1 = static_cast<int>(hi_r);

  const double p11 = g.precision(0, 0), p12 = g.precision(0, 1), p22 = g.precision(1, 1);
  const double e11 = std::exp(-p11), e12 = std::exp(-p12), e22 = std::exp(-p22);
  const double inv_e12 = 1.0 / e12, inv_e22 = 1.0 / e22;
  // Row k: |d2 + p12 d1 / p22| <= sqrt(K^2 Sigma_rr - d1^2) / (sqrt(det) p22).
  const double k2_srr = cutoff * cutoff * g.sigma2(0, 0);
  const double half_scale = 1.0 / (std::sqrt(g.det2) * p22);
  const double slope = p12 / p22;

  bool seeded = false, any = false;
  int anchor_a = 0;
  double e = 0, col_ratio = 0, row_ratio = 0;
  auto seed = [&](int k, int a) {
    const double d1 = k - g.mu_r, d2 = a - g.mu_a;
    e = std::exp(-0.5 * (p11 * d1 * d1 + 2 * p12 * d1 * d2 + p22 * d2 * d2));
    col_ratio = std::exp(-(p12 * d1 + p22 * (d2 + 0.5)));
    row_ratio = std::exp(-(p11 * (d1 + 0.5) + p12 * d2));
    anchor_a = a;
    seeded = true;
  };
  RowSpan span;
  for (int k = k0; k <= k1; ++k) {
    if (seeded && k > k0) {
      e *= row_ratio;
      col_ratio *= e12;
      row_ratio *= e11;
    }
    const double d1 = k - g.mu_r;
    const double disc = k2_srr - d1 * d1;
    if (disc < 0) {
      seeded = false;  // cannot happen inside the row range but for rounding; re-seed next row
      continue;
    }
    const double half = std::sqrt(disc) * half_scale;
    const double centre = g.mu_a - slope * d1;
    const double lo = fast_ceil(centre - half), hi = fast_floor(centre + half);
    if (lo > hi || hi < first_a || lo > last_a) continue;  // anchor stays valid for the next row
    const int a_lo = static_cast<int>(lo);
    // Re-seed when the walk would be long or the anchor drifted far outside the footprint
    // (skipped rows): keeps every carried value a normal double.
    if (!seeded || std::abs(a_lo - anchor_a) > kMaxWalk || !(e > 1e-150) || !(col_ratio < 1e150)) {
      seed(k, a_lo);
    } else {
      for (; anchor_a < a_lo; ++anchor_a) {
        e *= col_ratio;
        row_ratio *= e12;
        col_ratio *= e22;
      }
      for (; anchor_a > a_lo; --anchor_a) {
        col_ratio *= inv_e22;
        e /= col_ratio;
        row_ratio *= inv_e12;
      }
    }
    span.k = k;
    span.a0 = std::max(a_lo, first_a);
    span.a1 = std::min(static_cast<int>(hi), last_a);
    span.d1 = d1;
    span.d2 = span.a0 - g.mu_a;
    span.value = e;
    span.ratio = col_ratio;
    for (int a = a_lo; a < span.a0; ++a) {  // clipped on the left: walk to the first valid bin
      span.value *= span.ratio;
      span.ratio *= e22;
    }
    fn(span, e22);
    any = true;
  }
  return any;
}

// The scene's view returns are read only when the options use them, and a scene keeps them only
// when made to (SceneOptions::view_returns): refuse the pair that would read past its storage.
Context make_context(const RadarImageGrid& grid, const RaRenderOptions& o, const GaussianScene& scene) {
  if (o.view_dependent_return && !scene.has_view_returns())
    throw std::invalid_argument("RaRenderer: view_dependent_return needs a scene with view returns (SceneOptions::view_returns)");
  Context c;
  c.inv_range_bin = 1.0 / grid.range_bin_m;
  c.inv_azimuth_step = 1.0 / grid.azimuth_sin_step();
  c.azimuth_center = grid.azimuth_bins / 2;
  c.psf_var_range = grid.range_psf_sigma_bins * grid.range_psf_sigma_bins;
  const double sa = grid.azimuth_psf_sigma_bins();
  c.psf_var_azimuth = sa * sa;
  c.psf_sqrt_det = grid.range_psf_sigma_bins * sa;
  c.elevation_var = o.elevation_gain_sigma_sin > 0 ? o.elevation_gain_sigma_sin * o.elevation_gain_sigma_sin : 0;
  c.inv_azimuth_var = inverse_azimuth_variance(o);
  c.falloff_exponent = o.range_falloff_exponent;
  c.falloff_reference = o.range_falloff_reference_m;
  c.min_range = std::max(o.min_range_m, 1e-6);
  c.min_forward = o.min_forward_m;
  c.view_return = o.view_dependent_return;
  return c;
}

}  // namespace

PointGains point_gains(const RaRenderOptions& o, const Eigen::Vector3d& p) {
  PointGains g;
  const double range = p.norm();
  if (!(range > 0)) return g;
  // A zero-size Gaussian's elevation gain: project()'s sqrt(s^2 / tau) exp(-w^2 / 2 tau) with
  // tau = s^2.
  if (o.elevation_gain_sigma_sin > 0) {
    const double w = p.z() / range, s = o.elevation_gain_sigma_sin;
    g.elevation = std::exp(-0.5 * w * w / (s * s));
  }
  g.azimuth = azimuth_gain(std::atan2(p.y(), p.x()), inverse_azimuth_variance(o));
  g.falloff = range_falloff(o.range_falloff_exponent, o.range_falloff_reference_m, 1.0 / range);
  return g;
}

// ---------------------------------------------------------------------------------------------
template <typename Scalar>
RaRenderer<Scalar>::RaRenderer(const RadarImageGrid& grid, const RaRenderOptions& options)
    : grid_(grid), options_(options) {
  grid_.validate();
  if (!(options_.cutoff_sigma > 0)) throw std::invalid_argument("RaRenderOptions: cutoff_sigma must be positive");
  if (!(options_.range_falloff_reference_m > 0))
    throw std::invalid_argument("RaRenderOptions: range_falloff_reference_m must be positive");
  first_azimuth_ = grid_.first_valid_azimuth();
  last_azimuth_ = grid_.last_valid_azimuth();
}

template <typename Scalar>
template <typename Visit>
void RaRenderer<Scalar>::for_each(const GaussianScene& scene, const std::span<const std::uint32_t>* gaussians,
                                  Visit&& visit) const {
  if (gaussians == nullptr) {
    for (std::size_t i = 0; i < scene.size(); ++i) visit(i);
    return;
  }
  for (const std::uint32_t i : *gaussians)
    if (i < scene.size()) visit(static_cast<std::size_t>(i));
}

template <typename Scalar>
GaussianFootprint RaRenderer<Scalar>::footprint(const GaussianScene& scene, std::size_t i,
                                                const Eigen::Isometry3d& radar_T_world) const {
  const Context ctx = make_context(grid_, options_, scene);
  Projection g;
  project(scene, i, radar_T_world.linear(), radar_T_world.translation(), ctx, g);
  GaussianFootprint f;
  f.visible = g.visible;
  if (!g.visible) return f;
  f.range_bin = g.mu_r;
  f.azimuth_bin = g.mu_a;
  f.covariance = g.sigma2;
  f.amplitude = g.amplitude;
  return f;
}

template <typename Scalar>
RenderStats RaRenderer<Scalar>::render(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                       std::span<const std::uint32_t> gaussians, Image<Scalar>& image) const {
  return render_impl(scene, radar_T_world, &gaussians, image);
}

template <typename Scalar>
RenderStats RaRenderer<Scalar>::render(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                       Image<Scalar>& image) const {
  return render_impl(scene, radar_T_world, nullptr, image);
}

template <typename Scalar>
template <typename Pixel>
RenderStats RaRenderer<Scalar>::draw(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                     const std::span<const std::uint32_t>* gaussians, Pixel&& pixel) const {
  const Context ctx = make_context(grid_, options_, scene);
  const Eigen::Matrix3d r_tw = radar_T_world.linear();
  const Eigen::Vector3d t_tw = radar_T_world.translation();
  const int cols = grid_.azimuth_bins;
  RenderStats stats;
  Projection g;
  for_each(scene, gaussians, [&](std::size_t i) {
    project(scene, i, r_tw, t_tw, ctx, g);
    if (!g.visible) return;
    const Scalar amplitude = static_cast<Scalar>(g.amplitude);
    std::size_t pixels = 0;
    walk_rows(g, options_.cutoff_sigma, grid_.range_bins, first_azimuth_, last_azimuth_,
              [&](const RowSpan& s, double e22) {
                const std::ptrdiff_t base = static_cast<std::ptrdiff_t>(s.k) * cols;
                Scalar value = static_cast<Scalar>(s.value) * amplitude;
                Scalar ratio = static_cast<Scalar>(s.ratio);
                const Scalar step = static_cast<Scalar>(e22);
                for (int a = s.a0; a <= s.a1; ++a) {
                  pixel(g, base + a, value);
                  value *= ratio;
                  ratio *= step;
                }
                pixels += static_cast<std::size_t>(s.a1 - s.a0 + 1);
              });
    if (pixels > 0) ++stats.gaussians_drawn;
    stats.pixels += pixels;
  });
  return stats;
}

template <typename Scalar>
RenderStats RaRenderer<Scalar>::render_impl(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                            const std::span<const std::uint32_t>* gaussians,
                                            Image<Scalar>& image) const {
  if (image.rows() != grid_.range_bins || image.cols() != grid_.azimuth_bins)
    image.resize(grid_.range_bins, grid_.azimuth_bins);
  image.setZero();
  Scalar* data = image.data();
  return draw(scene, radar_T_world, gaussians, [data](const Projection&, std::ptrdiff_t p, Scalar value) { data[p] += value; });
}

template <typename Scalar>
void RaRenderer<Scalar>::render_directions(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                           std::span<const std::uint32_t> gaussians,
                                           PixelDirections<Scalar>& out) const {
  const int rows = grid_.range_bins, cols = grid_.azimuth_bins;
  for (Image<Scalar>* m : {&out.x, &out.y, &out.z, &out.weight}) {
    if (m->rows() != rows || m->cols() != cols) m->resize(rows, cols);
    m->setZero();
  }
  // Each Gaussian's unit direction in the radar frame, weighted by its contribution.
  draw(scene, radar_T_world, &gaussians, [&out](const Projection& g, std::ptrdiff_t p, Scalar value) {
    out.weight.data()[p] += value;
    out.x.data()[p] += value * static_cast<Scalar>(g.n.x());
    out.y.data()[p] += value * static_cast<Scalar>(g.n.y());
    out.z.data()[p] += value * static_cast<Scalar>(g.n.z());
  });
  for (int k = 0; k < rows; ++k)
    for (int a = 0; a < cols; ++a) {
      const Scalar w = out.weight(k, a);
      if (w > Scalar(0)) {
        out.x(k, a) /= w;
        out.y(k, a) /= w;
        out.z(k, a) /= w;
      } else {
        const double u = std::clamp(grid_.azimuth_sin(a), -1.0, 1.0);
        out.x(k, a) = static_cast<Scalar>(std::sqrt(1.0 - u * u));
        out.y(k, a) = static_cast<Scalar>(u);
        out.z(k, a) = Scalar(0);
      }
    }
}

template <typename Scalar>
void RaRenderer<Scalar>::backward(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                  std::span<const std::uint32_t> gaussians, const Image<Scalar>& grad_image,
                                  SceneGradients* gradients, Vector6d* grad_pose) const {
  backward_impl(scene, radar_T_world, &gaussians, grad_image, gradients, grad_pose);
}

template <typename Scalar>
void RaRenderer<Scalar>::backward(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                  const Image<Scalar>& grad_image, SceneGradients* gradients,
                                  Vector6d* grad_pose) const {
  backward_impl(scene, radar_T_world, nullptr, grad_image, gradients, grad_pose);
}

template <typename Scalar>
void RaRenderer<Scalar>::backward_impl(const GaussianScene& scene, const Eigen::Isometry3d& radar_T_world,
                                       const std::span<const std::uint32_t>* gaussians,
                                       const Image<Scalar>& grad_image, SceneGradients* gradients,
                                       Vector6d* grad_pose) const {
  if (grad_image.rows() != grid_.range_bins || grad_image.cols() != grid_.azimuth_bins)
    throw std::invalid_argument("RaRenderer::backward: gradient image has the wrong shape");
  if (gradients != nullptr && gradients->size() != scene.size())
    throw std::invalid_argument("RaRenderer::backward: gradients are not sized to the scene");
  if (gradients != nullptr && options_.view_dependent_return && gradients->view_returns.size() != kViewTerms * scene.size())
    throw std::invalid_argument("RaRenderer::backward: gradients have no view returns' block");
  const Context ctx = make_context(grid_, options_, scene);
  const Eigen::Matrix3d r_tw = radar_T_world.linear();
  const Eigen::Vector3d t_tw = radar_T_world.translation();
  const int cols = grid_.azimuth_bins;
  Eigen::Vector3d grad_rho_pose = Eigen::Vector3d::Zero();
  Eigen::Vector3d grad_omega_pose = Eigen::Vector3d::Zero();
  Projection g;
  for_each(scene, gaussians, [&](std::size_t i) {
    project(scene, i, r_tw, t_tw, ctx, g);
    if (!g.visible) return;
    // Pixel sums: S = sum g E, S_x = sum g E d_x, S_xy = sum g E d_x d_y (d = pixel - mean).
    double s0 = 0, s_1 = 0, s_2 = 0, s_11 = 0, s_12 = 0, s_22 = 0;
    const bool touched = walk_rows(
        g, options_.cutoff_sigma, grid_.range_bins, first_azimuth_, last_azimuth_, [&](const RowSpan& s, double e22) {
          const Scalar* row = grad_image.data() + static_cast<std::ptrdiff_t>(s.k) * cols;
          Scalar value = static_cast<Scalar>(s.value);
          Scalar ratio = static_cast<Scalar>(s.ratio);
          const Scalar step = static_cast<Scalar>(e22);
          Scalar d2 = static_cast<Scalar>(s.d2);
          Scalar r0 = 0, r1 = 0, r2 = 0;
          for (int a = s.a0; a <= s.a1; ++a) {
            const Scalar ge = row[a] * value;
            r0 += ge;
            r1 += ge * d2;
            r2 += ge * d2 * d2;
            d2 += Scalar(1);
            value *= ratio;
            ratio *= step;
          }
          s0 += r0;
          s_1 += s.d1 * r0;
          s_2 += r1;
          s_11 += s.d1 * s.d1 * r0;
          s_12 += s.d1 * r1;
          s_22 += r2;
        });
    if (!touched) return;

    // ---- footprint: I = A exp(-1/2 d^T P d), d = x - mu.
    const double amp = g.amplitude;
    const Eigen::Matrix2d& prec = g.precision;
    const double grad_amp = s0;
    const Eigen::Vector2d grad_mu = amp * (prec * Eigen::Vector2d(s_1, s_2));
    Eigen::Matrix2d grad_prec;
    grad_prec << s_11, s_12, s_12, s_22;
    grad_prec *= -0.5 * amp;
    // P = Sigma2^-1, and A ~ det(Sigma2)^-1/2.
    const Eigen::Matrix2d grad_sigma2 = -prec * grad_prec * prec - 0.5 * grad_amp * amp * prec;

    // ---- amplitude factors.
    const double grad_log_return = grad_amp * amp;
    const double grad_gain =
        grad_amp * g.rho * g.view * g.falloff * g.azimuth_gain * ctx.psf_sqrt_det / std::sqrt(g.det2);
    // View return: d log v / d c_k = b_k(phi); phi is the azimuth of d = R^T p = mu - (radar
    // position), so d phi / d mu = (-d_y, d_x, 0) / (d_x^2 + d_y^2), and under the pose's left
    // increment the radar position moves by -R^T rho (d by +R^T rho) while omega leaves it.
    Eigen::Vector3d grad_view_dir = Eigen::Vector3d::Zero();
    if (ctx.view_return && g.view_planar2 > 1e-18)
      grad_view_dir = grad_amp * amp * g.view_slope / g.view_planar2 *
                      Eigen::Vector3d(-g.view_dir.y(), g.view_dir.x(), 0.0);
    double grad_range_m = ctx.falloff_exponent != 0 ? -grad_amp * amp * ctx.falloff_exponent / g.range : 0.0;
    // Azimuth gain: d log(gain) / d theta = -theta / sigma^2, d theta / dp = (-p_y, p_x, 0) / (p_x^2 + p_y^2).
    const double grad_theta = ctx.inv_azimuth_var > 0 ? -grad_amp * amp * g.theta * ctx.inv_azimuth_var : 0.0;

    // ---- elevation: marginal or closed-form gain.
    Eigen::Matrix3d grad_sigma_pol = Eigen::Matrix3d::Zero();
    Eigen::Vector3d grad_mu_pol = Eigen::Vector3d::Zero();
    grad_sigma_pol.topLeftCorner<2, 2>() = grad_sigma2;
    grad_mu_pol.head<2>() = grad_mu;
    if (ctx.elevation_var > 0) {
      const double tau = g.tau, mw = g.w;
      const Eigen::Vector2d b = g.sigma_pol.block<2, 1>(0, 2);
      const double gmu_b = grad_mu.dot(b);
      const Eigen::Vector2d grad_b = -grad_mu * (mw / tau) - 2.0 * (grad_sigma2 * b) / tau;
      const double gc = grad_gain * g.gain;
      grad_mu_pol[2] = -gmu_b / tau - gc * mw / tau;
      const double grad_tau = gmu_b * mw / (tau * tau) + b.dot(grad_sigma2 * b) / (tau * tau) +
                              gc * (-0.5 / tau + 0.5 * mw * mw / (tau * tau));
      grad_sigma_pol.block<2, 1>(0, 2) = 0.5 * grad_b;
      grad_sigma_pol.block<1, 2>(2, 0) = 0.5 * grad_b.transpose();
      grad_sigma_pol(2, 2) = grad_tau;
    }

    // ---- polar projection: Sigma_pol = J Sigma_r J^T, mu_pol = mu_pol(p), J = d mu_pol / dp.
    const Eigen::Matrix3d grad_sigma_radar = g.jac.transpose() * grad_sigma_pol * g.jac;
    const Eigen::Matrix3d grad_jac = 2.0 * grad_sigma_pol * g.jac * g.sigma_radar;
    Eigen::Vector3d grad_p = g.jac.transpose() * grad_mu_pol;
    const double inv_r = 1.0 / g.range;
    grad_p += grad_range_m * g.n;
    if (grad_theta != 0) {
      const double rho2 = g.p.x() * g.p.x() + g.p.y() * g.p.y();
      grad_p += grad_theta / rho2 * Eigen::Vector3d(-g.p.y(), g.p.x(), 0.0);
    }
    {
      // Row 0: n / dr.
      const Eigen::Vector3d gj = grad_jac.row(0).transpose();
      grad_p += ctx.inv_range_bin * inv_r * (gj - gj.dot(g.n) * g.n);
    }
    auto direction_cosine_row = [&](const Eigen::Vector3d& gj, const Eigen::Vector3d& e, double c, double scale) {
      // Row (e - c n)^T scale / r with c = e.n.
      const Eigen::Vector3d a = e - c * g.n;
      const double gn = gj.dot(g.n);
      grad_p += scale * inv_r * inv_r * (-gn * a - c * (gj - gn * g.n) - gj.dot(a) * g.n);
    };
    direction_cosine_row(grad_jac.row(1).transpose(), Eigen::Vector3d::UnitY(), g.u, ctx.inv_azimuth_step);
    direction_cosine_row(grad_jac.row(2).transpose(), Eigen::Vector3d::UnitZ(), g.w, 1.0);

    // ---- pose (left increment): p <- p + rho + omega x p, Sigma_r <- Sigma_r + [w]x Sigma_r - Sigma_r [w]x.
    if (grad_pose != nullptr) {
      grad_rho_pose += grad_p + r_tw * grad_view_dir;
      grad_omega_pose += g.p.cross(grad_p) +
                         vee_antisym(g.sigma_radar * grad_sigma_radar - grad_sigma_radar * g.sigma_radar);
    }
    if (gradients == nullptr) return;

    // ---- world-frame mean and covariance.
    const Eigen::Vector3d grad_mean = r_tw.transpose() * grad_p + grad_view_dir;
    const Eigen::Matrix3d grad_sigma_world = r_tw.transpose() * grad_sigma_radar * r_tw;
    // Sigma = M M^T, M = R(q) diag(s).
    const Eigen::Matrix3d m = g.rot_q * g.scale.asDiagonal();
    const Eigen::Matrix3d grad_m = 2.0 * grad_sigma_world * m;
    Eigen::Vector3d grad_log_scale;
    for (int c = 0; c < 3; ++c) grad_log_scale[c] = grad_m.col(c).dot(g.rot_q.col(c)) * g.scale[c];
    const Eigen::Matrix3d grad_rot = grad_m * g.scale.asDiagonal();
    const Eigen::Vector4d grad_q_unit = rotation_to_quat_grad(g.q_unit, grad_rot);
    const Eigen::Vector4d grad_q = (grad_q_unit - g.q_unit * g.q_unit.dot(grad_q_unit)) / g.q_norm;

    for (int c = 0; c < 3; ++c) {
      gradients->means[3 * i + c] += grad_mean[c];
      gradients->log_scales[3 * i + c] += grad_log_scale[c];
    }
    for (int c = 0; c < 4; ++c) gradients->rotations[4 * i + c] += grad_q[c];
    gradients->log_returns[i] += grad_log_return;
    if (ctx.view_return)
      for (std::size_t c = 0; c < kViewTerms; ++c)
        gradients->view_returns[kViewTerms * i + c] += grad_log_return * g.view_basis[c];
    gradients->image_mean_grad_norm[i] += grad_mu.norm();
    gradients->visible_count[i] += 1;
  });
  if (grad_pose != nullptr) {
    grad_pose->head<3>() += grad_rho_pose;
    grad_pose->tail<3>() += grad_omega_pose;
  }
}

template class RaRenderer<float>;
template class RaRenderer<double>;

}  // namespace rsrio::splat
