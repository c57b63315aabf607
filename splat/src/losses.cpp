#include "rsrio/splat/losses.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rsrio::splat {

// ---------------------------------------------------------------------------------------------
// Compression
template <typename Scalar>
void compress(const Image<Scalar>& linear, const CompressionOptions& o, Image<Scalar>& out) {
  out.resize(linear.rows(), linear.cols());
  const Scalar* in = linear.data();
  Scalar* y = out.data();
  const Eigen::Index n = linear.size();
  if (o.logarithmic) {
    const double knee = o.floor * o.reference;
    const Scalar inv_knee = static_cast<Scalar>(1.0 / knee);
    const Scalar norm = static_cast<Scalar>(1.0 / std::log1p(1.0 / o.floor));
    for (Eigen::Index k = 0; k < n; ++k) y[k] = std::log1p(std::max(in[k], Scalar(0)) * inv_knee) * norm;
  } else {
    const Scalar inv_ref = static_cast<Scalar>(1.0 / o.reference);
    for (Eigen::Index k = 0; k < n; ++k) y[k] = in[k] * inv_ref;
  }
}

template <typename Scalar>
void compress_backward(const Image<Scalar>& linear, const Image<Scalar>& grad_compressed,
                       const CompressionOptions& o, Image<Scalar>& grad_linear) {
  grad_linear.resize(linear.rows(), linear.cols());
  const Scalar* in = linear.data();
  const Scalar* g = grad_compressed.data();
  Scalar* out = grad_linear.data();
  const Eigen::Index n = linear.size();
  if (o.logarithmic) {
    // dy/dx = 1 / ((knee + x) log(1 + 1/floor)) for x >= 0 (rendered images are >= 0; exact
    // zeros, pixels no Gaussian reaches, take the one-sided derivative).
    const Scalar knee = static_cast<Scalar>(o.floor * o.reference);
    const Scalar norm = static_cast<Scalar>(1.0 / std::log1p(1.0 / o.floor));
    for (Eigen::Index k = 0; k < n; ++k) out[k] = in[k] >= Scalar(0) ? g[k] * norm / (knee + in[k]) : Scalar(0);
  } else {
    const Scalar inv_ref = static_cast<Scalar>(1.0 / o.reference);
    for (Eigen::Index k = 0; k < n; ++k) out[k] = g[k] * inv_ref;
  }
}

double percentile_reference(std::span<const float> image, double percentile) {
  std::vector<float> positive;
  positive.reserve(image.size());
  for (const float v : image)
    if (v > 0 && std::isfinite(v)) positive.push_back(v);
  if (positive.empty()) return 1.0;
  const double q = std::clamp(percentile, 0.0, 100.0) / 100.0;
  const auto k = static_cast<std::size_t>(std::llround(q * static_cast<double>(positive.size() - 1)));
  std::nth_element(positive.begin(), positive.begin() + static_cast<std::ptrdiff_t>(k), positive.end());
  return positive[k];
}

// ---------------------------------------------------------------------------------------------
// L1
template <typename Scalar>
double l1_loss(const Image<Scalar>& x, const Image<Scalar>& y, Image<Scalar>* grad_x) {
  if (x.rows() != y.rows() || x.cols() != y.cols()) throw std::invalid_argument("l1_loss: shapes differ");
  const Eigen::Index n = x.size();
  if (n == 0) return 0.0;
  const Scalar inv_n = static_cast<Scalar>(1.0 / static_cast<double>(n));
  if (grad_x != nullptr) grad_x->resize(x.rows(), x.cols());
  double sum = 0;
  const Scalar* a = x.data();
  const Scalar* b = y.data();
  for (Eigen::Index k = 0; k < n; ++k) {
    const Scalar d = a[k] - b[k];
    sum += std::abs(static_cast<double>(d));
    if (grad_x != nullptr) grad_x->data()[k] = d > 0 ? inv_n : (d < 0 ? -inv_n : Scalar(0));
  }
  return sum / static_cast<double>(n);
}

// ---------------------------------------------------------------------------------------------
// SSIM
template <typename Scalar>
Ssim<Scalar>::Ssim(const SsimOptions& options) : options_(options) {
  if (options_.window < 1 || options_.window % 2 == 0) throw std::invalid_argument("SsimOptions: window must be odd");
  if (!(options_.sigma > 0)) throw std::invalid_argument("SsimOptions: sigma must be positive");
  const int half = options_.window / 2;
  double sum = 0;
  std::vector<double> k(options_.window);
  for (int i = 0; i < options_.window; ++i) {
    const double d = i - half;
    k[i] = std::exp(-d * d / (2 * options_.sigma * options_.sigma));
    sum += k[i];
  }
  kernel_.resize(options_.window);
  for (int i = 0; i < options_.window; ++i) kernel_[i] = static_cast<Scalar>(k[i] / sum);
}

template <typename Scalar>
void Ssim<Scalar>::filter_valid(const Image<Scalar>& in, Image<Scalar>& out) {
  const int w = options_.window;
  const Eigen::Index rows = in.rows(), cols = in.cols(), vr = rows - w + 1, vc = cols - w + 1;
  tmp_.resize(rows, vc);
  tmp_.setZero();
  // Tap-outer loops: the inner loop runs over contiguous columns and vectorises.
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Scalar* src = in.data() + r * cols;
    Scalar* dst = tmp_.data() + r * vc;
    for (int k = 0; k < w; ++k) {
      const Scalar g = kernel_[k];
      const Scalar* s = src + k;
      for (Eigen::Index c = 0; c < vc; ++c) dst[c] += g * s[c];
    }
  }
  out.resize(vr, vc);
  out.setZero();
  for (Eigen::Index r = 0; r < vr; ++r) {
    Scalar* dst = out.data() + r * vc;
    for (int k = 0; k < w; ++k) {
      const Scalar* src = tmp_.data() + (r + k) * vc;
      const Scalar g = kernel_[k];
      for (Eigen::Index c = 0; c < vc; ++c) dst[c] += g * src[c];
    }
  }
}

template <typename Scalar>
void Ssim<Scalar>::filter_adjoint(const Image<Scalar>& in, Image<Scalar>& out) {
  // Transpose of filter_valid: scatter every valid position back over its window.
  const int w = options_.window;
  const Eigen::Index vr = in.rows(), vc = in.cols(), rows = vr + w - 1, cols = vc + w - 1;
  tmp_.resize(rows, vc);
  tmp_.setZero();
  for (Eigen::Index r = 0; r < vr; ++r) {
    const Scalar* src = in.data() + r * vc;
    for (int k = 0; k < w; ++k) {
      Scalar* dst = tmp_.data() + (r + k) * vc;
      const Scalar g = kernel_[k];
      for (Eigen::Index c = 0; c < vc; ++c) dst[c] += g * src[c];
    }
  }
  out.resize(rows, cols);
  out.setZero();
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Scalar* src = tmp_.data() + r * vc;
    Scalar* dst = out.data() + r * cols;
    for (int k = 0; k < w; ++k) {
      const Scalar g = kernel_[k];
      Scalar* d = dst + k;
      for (Eigen::Index c = 0; c < vc; ++c) d[c] += g * src[c];
    }
  }
}

template <typename Scalar>
double Ssim<Scalar>::evaluate(const Image<Scalar>& x, const Image<Scalar>& y, Image<Scalar>* grad_x) {
  if (x.rows() != y.rows() || x.cols() != y.cols()) throw std::invalid_argument("Ssim: shapes differ");
  const int w = options_.window;
  if (grad_x != nullptr) {
    grad_x->resize(x.rows(), x.cols());
    grad_x->setZero();
  }
  if (x.rows() < w || x.cols() < w) return 1.0;
  xx_ = x.cwiseProduct(x);
  yy_ = y.cwiseProduct(y);
  xy_ = x.cwiseProduct(y);
  filter_valid(x, mu_x_);
  filter_valid(y, mu_y_);
  filter_valid(xx_, e_xx_);
  filter_valid(yy_, e_yy_);
  filter_valid(xy_, e_xy_);
  const Eigen::Index vr = mu_x_.rows(), vc = mu_x_.cols(), nv = vr * vc;
  const double c1 = options_.c1, c2 = options_.c2;
  const double inv_nv = 1.0 / static_cast<double>(nv);
  if (grad_x != nullptr) {
    c_mx_.resize(vr, vc);
    c_xx_.resize(vr, vc);
    c_xy_.resize(vr, vc);
  }
  double sum = 0;
  for (Eigen::Index k = 0; k < nv; ++k) {
    const double mx = mu_x_.data()[k], my = mu_y_.data()[k];
    const double vx = e_xx_.data()[k] - mx * mx, vy = e_yy_.data()[k] - my * my;
    const double cxy = e_xy_.data()[k] - mx * my;
    const double n1 = 2 * mx * my + c1, n2 = 2 * cxy + c2;
    const double d1 = mx * mx + my * my + c1, d2 = vx + vy + c2;
    const double s = n1 * n2 / (d1 * d2);
    sum += s;
    if (grad_x == nullptr) continue;
    // S(mu_x, E_xx, E_xy): sigma_x^2 = E_xx - mu_x^2, sigma_xy = E_xy - mu_x mu_y.
    const double d_vx = -s / d2;                   // dS / d sigma_x^2 = dS / dE_xx
    const double d_cxy = 2 * n1 / (d1 * d2);       // dS / d sigma_xy = dS / dE_xy
    const double d_mx = 2 * my * n2 / (d1 * d2) - 2 * mx * s / d1;  // at fixed sigmas
    c_mx_.data()[k] = static_cast<Scalar>((d_mx - 2 * mx * d_vx - my * d_cxy) * inv_nv);
    c_xx_.data()[k] = static_cast<Scalar>(d_vx * inv_nv);
    c_xy_.data()[k] = static_cast<Scalar>(d_cxy * inv_nv);
  }
  if (grad_x != nullptr) {
    // d mean S / dx_p = (W^T c_mx)_p + 2 x_p (W^T c_xx)_p + y_p (W^T c_xy)_p.
    filter_adjoint(c_mx_, a_mx_);
    filter_adjoint(c_xx_, a_xx_);
    filter_adjoint(c_xy_, a_xy_);
    *grad_x = a_mx_ + Scalar(2) * x.cwiseProduct(a_xx_) + y.cwiseProduct(a_xy_);
  }
  return sum * inv_nv;
}

// ---------------------------------------------------------------------------------------------
// Combined image loss
template <typename Scalar>
ImageLoss<Scalar>::ImageLoss(const ImageLossOptions& options) : options_(options), ssim_(options.ssim) {
  if (!(options_.compression.reference > 0) || !(options_.compression.floor > 0))
    throw std::invalid_argument("CompressionOptions: reference and floor must be positive");
  if (options_.skip_near_range_bins < 0) throw std::invalid_argument("ImageLossOptions: skip_near_range_bins < 0");
}

template <typename Scalar>
void ImageLoss<Scalar>::prepare_measurement(const Image<Scalar>& measured_linear,
                                            Image<Scalar>& measured_compressed) const {
  compress(measured_linear, options_.compression, measured_compressed);
}

template <typename Scalar>
double ImageLoss<Scalar>::evaluate(const Image<Scalar>& rendered_linear, const Image<Scalar>& measured_compressed,
                                   Image<Scalar>* grad_rendered) {
  if (rendered_linear.rows() != measured_compressed.rows() || rendered_linear.cols() != measured_compressed.cols())
    throw std::invalid_argument("ImageLoss: rendered and measured shapes differ");
  const Eigen::Index skip = std::min<Eigen::Index>(options_.skip_near_range_bins, rendered_linear.rows());
  const Eigen::Index rows = rendered_linear.rows() - skip;
  compress(rendered_linear, options_.compression, compressed_);
  rendered_part_ = compressed_.bottomRows(rows);
  measured_part_ = measured_compressed.bottomRows(rows);
  const bool want = grad_rendered != nullptr;
  double loss = 0;
  if (options_.l1_weight != 0)
    loss += options_.l1_weight * l1_loss(rendered_part_, measured_part_, want ? &grad_l1_ : nullptr);
  if (options_.ssim_weight != 0)
    loss += options_.ssim_weight * (1.0 - ssim_.evaluate(rendered_part_, measured_part_, want ? &grad_ssim_ : nullptr));
  if (!want) return loss;
  grad_compressed_.resize(rendered_linear.rows(), rendered_linear.cols());
  grad_compressed_.setZero();
  auto part = grad_compressed_.bottomRows(rows);
  if (options_.l1_weight != 0) part += static_cast<Scalar>(options_.l1_weight) * grad_l1_;
  if (options_.ssim_weight != 0) part -= static_cast<Scalar>(options_.ssim_weight) * grad_ssim_;
  compress_backward(rendered_linear, grad_compressed_, options_.compression, *grad_rendered);
  return loss;
}

// ---------------------------------------------------------------------------------------------
namespace {

// visit(i) for the listed Gaussians in the scene, or for all of them when the list is empty.
template <typename Visit>
void for_listed(const GaussianScene& scene, std::span<const std::uint32_t> gaussians, Visit&& visit) {
  if (gaussians.empty()) {
    for (std::size_t i = 0; i < scene.size(); ++i) visit(i);
    return;
  }
  for (const std::uint32_t i : gaussians)
    if (i < scene.size()) visit(i);
}

}  // namespace

double scale_regulariser(const GaussianScene& scene, std::span<const std::uint32_t> gaussians,
                         const ScaleRegulariserOptions& options, SceneGradients* gradients) {
  const std::size_t n = gaussians.empty() ? scene.size() : gaussians.size();
  if (n == 0) return 0.0;
  const double factor = options.weight / (3.0 * static_cast<double>(n));
  const auto log_scales = scene.log_scales();
  double sum = 0;
  auto visit = [&](std::size_t i) {
    for (int c = 0; c < 3; ++c) {
      const double s = std::exp(log_scales[3 * i + c]);
      if (s <= options.max_scale_m) continue;
      sum += s - options.max_scale_m;
      if (gradients != nullptr) gradients->log_scales[3 * i + c] += factor * s;
    }
  };
  for_listed(scene, gaussians, visit);
  return factor * sum;
}

double view_return_regulariser(const GaussianScene& scene, std::span<const std::uint32_t> gaussians,
                               double weight, SceneGradients* gradients) {
  if (!scene.has_view_returns()) return 0.0;  // no terms to hold
  if (gradients != nullptr && gradients->view_returns.size() != scene.view_returns().size())
    throw std::invalid_argument("view_return_regulariser: gradients have no view returns' block");
  const std::size_t n = gaussians.empty() ? scene.size() : gaussians.size();
  if (n == 0 || weight == 0) return 0.0;
  const double factor = weight / static_cast<double>(kViewTerms * n);
  const auto view = scene.view_returns();
  double sum = 0;
  auto visit = [&](std::size_t i) {
    for (std::size_t c = kViewTerms * i; c < kViewTerms * (i + 1); ++c) {
      sum += view[c] * view[c];
      if (gradients != nullptr) gradients->view_returns[c] += 2 * factor * view[c];
    }
  };
  for_listed(scene, gaussians, visit);
  return factor * sum;
}

// ---------------------------------------------------------------------------------------------
template void compress<float>(const Image<float>&, const CompressionOptions&, Image<float>&);
template void compress<double>(const Image<double>&, const CompressionOptions&, Image<double>&);
template void compress_backward<float>(const Image<float>&, const Image<float>&, const CompressionOptions&, Image<float>&);
template void compress_backward<double>(const Image<double>&, const Image<double>&, const CompressionOptions&,
                                        Image<double>&);
template double l1_loss<float>(const Image<float>&, const Image<float>&, Image<float>*);
template double l1_loss<double>(const Image<double>&, const Image<double>&, Image<double>*);
template class Ssim<float>;
template class Ssim<double>;
template class ImageLoss<float>;
template class ImageLoss<double>;

}  // namespace rsrio::splat
