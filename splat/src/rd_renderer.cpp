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
  taps_ = 2 * options_.window_bins + 1;
  const int na = grid_.azimuth_bins;
  cos_.resize(na);
  sin_.resize(na);
  phi_.resize(na);
  for (int a = 0; a < na; ++a) {
    sin_[a] = grid_.azimuth_sin(a);
    const bool valid = grid_.azimuth_valid(a);
    cos_[a] = valid ? std::sqrt(1.0 - sin_[a] * sin_[a]) : 0.0;
    phi_[a] = valid ? static_cast<Scalar>(options_.gain * options_.antenna.weight(sin_[a])) : Scalar(0);
  }
  index_.assign(static_cast<std::size_t>(na) * taps_, 0);
  weight_.assign(static_cast<std::size_t>(na) * taps_, Scalar(0));
  weight_dv_.assign(static_cast<std::size_t>(na) * taps_, Scalar(0));
  active_.assign(na, 0);
  grad_vd_.assign(na, 0.0);
}

template <typename Scalar>
void RdRenderer<Scalar>::prepare(const Eigen::Vector3d& velocity) {
  const int na = grid_.azimuth_bins, nd = grid_.doppler_bins, w = options_.window_bins;
  const double sigma = options_.kernel_sigma_bins;
  const double inv_var = 1.0 / (sigma * sigma);
  const double inv_bin = 1.0 / grid_.velocity_bin_mps;
  for (int a = 0; a < na; ++a) {
    const double vd = -(velocity.x() * cos_[a] + velocity.y() * sin_[a]);
    const double centre = vd * inv_bin + nd / 2;  // continuous Doppler bin
    active_[a] = phi_[a] != Scalar(0) && std::isfinite(centre) && std::abs(centre) < 1e7;
    if (!active_[a]) continue;
    const long nearest = std::lround(centre);
    for (int k = 0; k < taps_; ++k) {
      const long j = nearest - w + k;
      const double delta = static_cast<double>(j) - centre;  // bins
      const double kernel = std::exp(-0.5 * delta * delta * inv_var);
      const std::size_t t = static_cast<std::size_t>(a) * taps_ + k;
      index_[t] = static_cast<int>(((j % nd) + nd) % nd);
      weight_[t] = static_cast<Scalar>(phi_[a] * kernel);
      // d delta / d v_D = -1 / bin, d kernel / d delta = -kernel delta / sigma^2.
      weight_dv_[t] = static_cast<Scalar>(phi_[a] * kernel * delta * inv_var * inv_bin);
    }
  }
}

template <typename Scalar>
void RdRenderer<Scalar>::render(const Image<Scalar>& ra, const Eigen::Vector3d& velocity, Image<Scalar>& rd) {
  if (ra.rows() != grid_.range_bins || ra.cols() != grid_.azimuth_bins)
    throw std::invalid_argument("RdRenderer::render: RA image has the wrong shape");
  if (rd.rows() != grid_.range_bins || rd.cols() != grid_.doppler_bins) rd.resize(grid_.range_bins, grid_.doppler_bins);
  rd.setZero();
  prepare(velocity);
  const int na = grid_.azimuth_bins, nd = grid_.doppler_bins;
  for (int r = 0; r < grid_.range_bins; ++r) {
    const Scalar* in = ra.data() + static_cast<std::ptrdiff_t>(r) * na;
    Scalar* out = rd.data() + static_cast<std::ptrdiff_t>(r) * nd;
    for (int a = 0; a < na; ++a) {
      const Scalar x = in[a];
      if (x == Scalar(0) || !active_[a]) continue;
      const std::size_t base = static_cast<std::size_t>(a) * taps_;
      for (int k = 0; k < taps_; ++k) out[index_[base + k]] += x * weight_[base + k];
    }
  }
}

template <typename Scalar>
void RdRenderer<Scalar>::backward(const Image<Scalar>& ra, const Eigen::Vector3d& velocity,
                                  const Image<Scalar>& grad_rd, Image<Scalar>* grad_ra,
                                  Eigen::Vector3d* grad_velocity) {
  if (ra.rows() != grid_.range_bins || ra.cols() != grid_.azimuth_bins ||
      grad_rd.rows() != grid_.range_bins || grad_rd.cols() != grid_.doppler_bins)
    throw std::invalid_argument("RdRenderer::backward: image shapes do not match the grid");
  if (grad_ra != nullptr && (grad_ra->rows() != ra.rows() || grad_ra->cols() != ra.cols())) {
    grad_ra->resize(ra.rows(), ra.cols());
    grad_ra->setZero();
  }
  prepare(velocity);
  const int na = grid_.azimuth_bins, nd = grid_.doppler_bins;
  std::fill(grad_vd_.begin(), grad_vd_.end(), 0.0);
  for (int r = 0; r < grid_.range_bins; ++r) {
    const Scalar* in = ra.data() + static_cast<std::ptrdiff_t>(r) * na;
    const Scalar* g = grad_rd.data() + static_cast<std::ptrdiff_t>(r) * nd;
    Scalar* gra = grad_ra != nullptr ? grad_ra->data() + static_cast<std::ptrdiff_t>(r) * na : nullptr;
    for (int a = 0; a < na; ++a) {
      if (!active_[a]) continue;
      const std::size_t base = static_cast<std::size_t>(a) * taps_;
      Scalar sum = 0, sum_dv = 0;
      for (int k = 0; k < taps_; ++k) {
        const Scalar gk = g[index_[base + k]];
        sum += gk * weight_[base + k];
        sum_dv += gk * weight_dv_[base + k];
      }
      if (gra != nullptr) gra[a] += sum;
      grad_vd_[a] += static_cast<double>(in[a] * sum_dv);
    }
  }
  if (grad_velocity != nullptr) {
    for (int a = 0; a < na; ++a) {
      if (!active_[a]) continue;
      // v_D = -(v_x cos + v_y sin).
      grad_velocity->x() -= grad_vd_[a] * cos_[a];
      grad_velocity->y() -= grad_vd_[a] * sin_[a];
    }
  }
}

template class RdRenderer<float>;
template class RdRenderer<double>;

}  // namespace rsrio::splat
