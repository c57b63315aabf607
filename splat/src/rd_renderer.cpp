#include "rsrio/splat/rd_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace rsrio::splat {

double AntennaProfile::weight(double sin_theta) const {
  const double s = std::clamp(sin_theta, -1.0, 1.0);
  switch (kind) {
    case Kind::kUniform:
      return 1.0;
    case Kind::kCosinePower:
      return std::pow(std::sqrt(1.0 - s * s), exponent);
    case Kind::kDartAwr1843: {
      const double a = std::asin(s) * 180.0 / std::numbers::pi / 56.0;
      const double a2 = a * a;
      const double db = 0.14 * a2 * a2 * a2 + 0.13 * a2 * a2 - 8.2 * a2;
      return std::pow(10.0, db / 10.0);
    }
  }
  return 1.0;
}

int effective_window(const RdRenderOptions& options) {
  // Beyond 8 sigma the kernel is below exp(-32) = 1.3e-14 of its peak: nothing in float images.
  const double cut = std::ceil(8.0 * options.kernel_sigma_bins);
  return cut < options.window_bins ? static_cast<int>(cut) : options.window_bins;
}

double static_doppler(const Eigen::Vector3d& velocity, double sin_theta) {
  const double c = std::sqrt(std::max(0.0, 1.0 - sin_theta * sin_theta));
  return -(velocity.x() * c + velocity.y() * sin_theta);
}

template <typename Scalar>
RdRenderer<Scalar>::RdRenderer(const RadarImageGrid& grid, const RdRenderOptions& options)
    : grid_(grid), options_(options) {
  grid_.validate();
  if (!(options_.kernel_sigma_bins > 0)) throw std::invalid_argument("RdRenderOptions: kernel_sigma_bins must be positive");
  if (options_.window_bins < 0) throw std::invalid_argument("RdRenderOptions: window_bins must be >= 0");
  if (!(options_.elevation_sigma_sin >= 0 && options_.elevation_sigma_sin < 0.5))
    throw std::invalid_argument("RdRenderOptions: elevation_sigma_sin must be in [0, 0.5)");
  window_ = effective_window(options_);
  taps_ = 2 * window_ + 1;
  // Elevation nodes: 3-point Gauss-Hermite in sin(elevation) (exact for the beam's mean and
  // variance), or elevation 0 alone.
  std::vector<double> node_weight;
  if (options_.elevation_sigma_sin > 0) {
    const double e = std::sqrt(3.0) * options_.elevation_sigma_sin;
    node_sin_ = {-e, 0.0, e};
    node_weight = {1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0};
  } else {
    node_sin_ = {0.0};
    node_weight = {1.0};
  }
  nodes_ = static_cast<int>(node_sin_.size());
  bin_taps_ = nodes_ * taps_;
  const int na = grid_.azimuth_bins;
  cos_.assign(static_cast<std::size_t>(na) * nodes_, 0.0);
  sin_.resize(na);
  phi_.resize(na);
  node_phi_.assign(static_cast<std::size_t>(na) * nodes_, Scalar(0));
  for (int a = 0; a < na; ++a) {
    sin_[a] = grid_.azimuth_sin(a);
    const bool valid = grid_.azimuth_valid(a);
    phi_[a] = valid ? static_cast<Scalar>(options_.gain * options_.antenna.weight(sin_[a])) : Scalar(0);
    for (int q = 0; q < nodes_; ++q) {
      // The direction (sqrt(cos^2 el - u^2), u, sin el): its forward part; none where the
      // elevation leaves no room for the azimuth (|u| > cos el).
      const double cos2_el = 1.0 - node_sin_[q] * node_sin_[q], forward2 = cos2_el - sin_[a] * sin_[a];
      const std::size_t i = static_cast<std::size_t>(a) * nodes_ + q;
      if (!valid || forward2 < 0) continue;
      cos_[i] = std::sqrt(forward2);
      node_phi_[i] = static_cast<Scalar>(static_cast<double>(phi_[a]) * node_weight[q]);
    }
  }
  index_.assign(static_cast<std::size_t>(na) * bin_taps_, 0);
  weight_.assign(static_cast<std::size_t>(na) * bin_taps_, Scalar(0));
  weight_dv_.assign(static_cast<std::size_t>(na) * bin_taps_, Scalar(0));
  active_.assign(static_cast<std::size_t>(na) * nodes_, 0);
  bin_active_.assign(na, 0);
  grad_vd_.assign(static_cast<std::size_t>(na) * nodes_, 0.0);
  kernel_step_ = std::exp(-1.0 / (options_.kernel_sigma_bins * options_.kernel_sigma_bins));
  pixel_index_.assign(static_cast<std::size_t>(taps_), 0);
  pixel_weight_.assign(static_cast<std::size_t>(taps_), Scalar(0));
  pixel_weight_dv_.assign(static_cast<std::size_t>(taps_), Scalar(0));
}

template <typename Scalar>
bool RdRenderer<Scalar>::pixel_taps(double vd, double phi, bool derivatives) {
  const int nd = grid_.doppler_bins, w = window_;
  const double inv_var = 1.0 / (options_.kernel_sigma_bins * options_.kernel_sigma_bins);
  const double inv_bin = 1.0 / grid_.velocity_bin_mps;
  const double centre = vd * inv_bin + nd / 2;  // continuous Doppler bin
  if (!std::isfinite(centre) || !(std::abs(centre) < 1e7)) return false;  // as prepare(): no such pixel
  const long nearest = std::lround(centre);
  const double d0 = static_cast<double>(nearest) - centre;  // in [-1/2, 1/2]
  int j = static_cast<int>((((nearest - w) % nd) + nd) % nd);
  for (int t = 0; t < taps_; ++t, j = j + 1 == nd ? 0 : j + 1) pixel_index_[static_cast<std::size_t>(t)] = j;
  const double dv_scale = inv_var * inv_bin;
  auto set = [&](int m, double kernel) {
    const auto t = static_cast<std::size_t>(m + w);
    pixel_weight_[t] = static_cast<Scalar>(phi * kernel);
    if (derivatives) pixel_weight_dv_[t] = static_cast<Scalar>(phi * kernel * (d0 + m) * dv_scale);
  };
  // exp(-delta^2 / (2 sigma^2)) at delta = d0 + m, m = -w..w, by its recurrence outwards from
  // the centre: e(m +- 1) = e(m) exp(-(1/2 +- (d0 + m)) / sigma^2), factors <= 1, so nothing
  // overflows for any sigma; the two first factors multiply to exp(-1 / sigma^2).
  const double e0 = std::exp(-0.5 * d0 * d0 * inv_var);
  set(0, e0);
  const double up = std::exp(-(0.5 + d0) * inv_var);
  const double down = up > 1e-300 ? kernel_step_ / up : std::exp(-(0.5 - d0) * inv_var);
  double e = e0, r = up;
  for (int m = 1; m <= w; ++m, r *= kernel_step_) set(m, e *= r);
  e = e0;
  r = down;
  for (int m = -1; m >= -w; --m, r *= kernel_step_) set(m, e *= r);
  return true;
}

template <typename Scalar>
void RdRenderer<Scalar>::check_directions(const PixelDirections<Scalar>* d) const {
  if (d == nullptr) return;
  for (const Image<Scalar>* m : {&d->x, &d->y, &d->z})
    if (m->rows() != grid_.range_bins || m->cols() != grid_.azimuth_bins)
      throw std::invalid_argument("RdRenderer: pixel directions have the wrong shape");
}

template <typename Scalar>
void RdRenderer<Scalar>::prepare(const Eigen::Vector3d& velocity) {
  const int na = grid_.azimuth_bins, nd = grid_.doppler_bins, w = window_;
  const double sigma = options_.kernel_sigma_bins;
  const double inv_var = 1.0 / (sigma * sigma);
  const double inv_bin = 1.0 / grid_.velocity_bin_mps;
  for (int a = 0; a < na; ++a) {
    bin_active_[a] = 0;
    for (int q = 0; q < nodes_; ++q) {
      const std::size_t i = static_cast<std::size_t>(a) * nodes_ + q;
      const double vd = -(velocity.x() * cos_[i] + velocity.y() * sin_[a] + velocity.z() * node_sin_[q]);
      double centre = vd * inv_bin + nd / 2;  // continuous Doppler bin
      active_[i] = node_phi_[i] != Scalar(0) && std::isfinite(centre) && std::abs(centre) < 1e7;
      // An inactive node keeps its taps with zero weight: an azimuth bin's taps are one run.
      if (!active_[i]) centre = 0;
      const long nearest = std::lround(centre);
      const double phi = active_[i] ? static_cast<double>(node_phi_[i]) : 0.0;
      if (active_[i]) bin_active_[a] = 1;
      for (int k = 0; k < taps_; ++k) {
        const long j = nearest - w + k;
        const double delta = static_cast<double>(j) - centre;  // bins
        const double kernel = std::exp(-0.5 * delta * delta * inv_var);
        const std::size_t t = i * taps_ + k;
        index_[t] = static_cast<int>(((j % nd) + nd) % nd);
        weight_[t] = static_cast<Scalar>(phi * kernel);
        // d delta / d v_D = -1 / bin, d kernel / d delta = -kernel delta / sigma^2.
        weight_dv_[t] = static_cast<Scalar>(phi * kernel * delta * inv_var * inv_bin);
      }
    }
  }
}

template <typename Scalar>
void RdRenderer<Scalar>::render(const Image<Scalar>& ra, const Eigen::Vector3d& velocity, Image<Scalar>& rd,
                                const PixelDirections<Scalar>* directions) {
  if (ra.rows() != grid_.range_bins || ra.cols() != grid_.azimuth_bins)
    throw std::invalid_argument("RdRenderer::render: RA image has the wrong shape");
  check_directions(directions);
  if (rd.rows() != grid_.range_bins || rd.cols() != grid_.doppler_bins) rd.resize(grid_.range_bins, grid_.doppler_bins);
  rd.setZero();
  const int na = grid_.azimuth_bins, nd = grid_.doppler_bins;
  if (directions != nullptr) {
    for (int r = 0; r < grid_.range_bins; ++r) {
      const Scalar* in = ra.data() + static_cast<std::ptrdiff_t>(r) * na;
      Scalar* out = rd.data() + static_cast<std::ptrdiff_t>(r) * nd;
      for (int a = 0; a < na; ++a) {
        const Scalar x = in[a];
        if (x == Scalar(0) || phi_[a] == Scalar(0)) continue;
        const double vd = -(velocity.x() * directions->x(r, a) + velocity.y() * directions->y(r, a) +
                            velocity.z() * directions->z(r, a));
        if (!pixel_taps(vd, static_cast<double>(phi_[a]), false)) continue;
        for (int k = 0; k < taps_; ++k) out[pixel_index_[k]] += x * pixel_weight_[k];
      }
    }
    return;
  }
  prepare(velocity);
  for (int r = 0; r < grid_.range_bins; ++r) {
    const Scalar* in = ra.data() + static_cast<std::ptrdiff_t>(r) * na;
    Scalar* out = rd.data() + static_cast<std::ptrdiff_t>(r) * nd;
    for (int a = 0; a < na; ++a) {
      const Scalar x = in[a];
      if (x == Scalar(0) || !bin_active_[a]) continue;
      const std::size_t base = static_cast<std::size_t>(a) * bin_taps_;
      for (int k = 0; k < bin_taps_; ++k) out[index_[base + k]] += x * weight_[base + k];
    }
  }
}

template <typename Scalar>
void RdRenderer<Scalar>::backward(const Image<Scalar>& ra, const Eigen::Vector3d& velocity,
                                  const Image<Scalar>& grad_rd, Image<Scalar>* grad_ra,
                                  Eigen::Vector3d* grad_velocity, const PixelDirections<Scalar>* directions) {
  if (ra.rows() != grid_.range_bins || ra.cols() != grid_.azimuth_bins ||
      grad_rd.rows() != grid_.range_bins || grad_rd.cols() != grid_.doppler_bins)
    throw std::invalid_argument("RdRenderer::backward: image shapes do not match the grid");
  check_directions(directions);
  if (grad_ra != nullptr && (grad_ra->rows() != ra.rows() || grad_ra->cols() != ra.cols())) {
    grad_ra->resize(ra.rows(), ra.cols());
    grad_ra->setZero();
  }
  const int na = grid_.azimuth_bins, nd = grid_.doppler_bins;
  if (directions != nullptr) {
    Eigen::Vector3d grad_v = Eigen::Vector3d::Zero();
    for (int r = 0; r < grid_.range_bins; ++r) {
      const Scalar* in = ra.data() + static_cast<std::ptrdiff_t>(r) * na;
      const Scalar* g = grad_rd.data() + static_cast<std::ptrdiff_t>(r) * nd;
      Scalar* gra = grad_ra != nullptr ? grad_ra->data() + static_cast<std::ptrdiff_t>(r) * na : nullptr;
      for (int a = 0; a < na; ++a) {
        // A pixel nothing is drawn into passes no gradient on (header).
        if (phi_[a] == Scalar(0) || in[a] == Scalar(0)) continue;
        const Eigen::Vector3d d(directions->x(r, a), directions->y(r, a), directions->z(r, a));
        if (!pixel_taps(-velocity.dot(d), static_cast<double>(phi_[a]), true)) continue;
        Scalar sum = 0, sum_dv = 0;
        for (int k = 0; k < taps_; ++k) {
          const Scalar gk = g[pixel_index_[k]];
          sum += gk * pixel_weight_[k];
          sum_dv += gk * pixel_weight_dv_[k];
        }
        if (gra != nullptr) gra[a] += sum;
        grad_v -= static_cast<double>(in[a] * sum_dv) * d;  // v_D = -d . v
      }
    }
    if (grad_velocity != nullptr) *grad_velocity += grad_v;
    return;
  }
  prepare(velocity);
  std::fill(grad_vd_.begin(), grad_vd_.end(), 0.0);
  for (int r = 0; r < grid_.range_bins; ++r) {
    const Scalar* in = ra.data() + static_cast<std::ptrdiff_t>(r) * na;
    const Scalar* g = grad_rd.data() + static_cast<std::ptrdiff_t>(r) * nd;
    Scalar* gra = grad_ra != nullptr ? grad_ra->data() + static_cast<std::ptrdiff_t>(r) * na : nullptr;
    for (int a = 0; a < na; ++a) {
      if (!bin_active_[a]) continue;
      Scalar sum = 0;
      for (int q = 0; q < nodes_; ++q) {
        const std::size_t i = static_cast<std::size_t>(a) * nodes_ + q, base = i * taps_;
        Scalar sum_dv = 0;
        for (int k = 0; k < taps_; ++k) {
          const Scalar gk = g[index_[base + k]];
          sum += gk * weight_[base + k];
          sum_dv += gk * weight_dv_[base + k];
        }
        grad_vd_[i] += static_cast<double>(in[a] * sum_dv);
      }
      if (gra != nullptr) gra[a] += sum;
    }
  }
  if (grad_velocity != nullptr) {
    for (int a = 0; a < na; ++a)
      for (int q = 0; q < nodes_; ++q) {
        const std::size_t i = static_cast<std::size_t>(a) * nodes_ + q;
        if (!active_[i]) continue;
        // v_D = -(v_x cos + v_y sin(theta) + v_z sin(elevation)).
        grad_velocity->x() -= grad_vd_[i] * cos_[i];
        grad_velocity->y() -= grad_vd_[i] * sin_[a];
        grad_velocity->z() -= grad_vd_[i] * node_sin_[q];
      }
  }
}

template class RdRenderer<float>;
template class RdRenderer<double>;

}  // namespace rsrio::splat
