#include "nufft.hpp"

#include "kernels.hpp"

#include <algorithm>
#include <numbers>
#include <stdexcept>

#include <Eigen/Dense>

namespace rsrio::sim::detail {

InverseFft::InverseFft(int size) : n_(size) {
  if (size < 2 || (size & (size - 1)) != 0) throw std::invalid_argument("FFT size must be a power of two");
  int bits = 0;
  while ((1 << bits) < size) ++bits;
  bitrev_.resize(static_cast<std::size_t>(size));
  for (int i = 0; i < size; ++i) {
    int j = 0;
    for (int b = 0; b < bits; ++b)
      if (i & (1 << b)) j |= 1 << (bits - 1 - b);
    bitrev_[i] = j;
  }
  tw_re_.assign(static_cast<std::size_t>(size), 0.0f);
  tw_im_.assign(static_cast<std::size_t>(size), 0.0f);
  for (int h = 1; h < size; h *= 2)
    for (int k = 0; k < h; ++k) {
      const double a = std::numbers::pi * k / h;
      tw_re_[h + k] = static_cast<float>(std::cos(a));
      tw_im_[h + k] = static_cast<float>(std::sin(a));
    }
}

void InverseFft::run(float* re, float* im) const { fft_dif(n_, re, im, tw_re_.data(), tw_im_.data()); }

SpreadKernel::SpreadKernel() : beta_(2.30 * kWidth) {
  // Least-squares fit in double on Chebyshev-distributed points of each tap's curve, variable
  // s = 2 frac - 1 in [-1, 1] where monomials are well conditioned at this degree.
  constexpr int kPoints = 200;
  Eigen::MatrixXd vandermonde(kPoints, kDegree + 1);
  Eigen::VectorXd s(kPoints);
  for (int i = 0; i < kPoints; ++i) {
    s[i] = -std::cos(std::numbers::pi * (i + 0.5) / kPoints);
    double p = 1;
    for (int d = 0; d <= kDegree; ++d, p *= s[i]) vandermonde(i, d) = p;
  }
  const auto qr = vandermonde.colPivHouseholderQr();
  for (int k = 0; k < kWidth; ++k) {
    Eigen::VectorXd y(kPoints);
    for (int i = 0; i < kPoints; ++i) y[i] = exact(k - (kWidth / 2 - 1) - 0.5 * (s[i] + 1));
    const Eigen::VectorXd c = qr.solve(y);
    for (int d = 0; d <= kDegree; ++d) coef_[d * kWidth + k] = static_cast<float>(c[d]);
  }
  // Check the float evaluation against the exact kernel on a fine grid.
  float t[kWidth];
  for (int i = 0; i <= 4000; ++i) {
    const double frac = std::min(i / 4000.0, 1.0 - 1e-9);
    taps(static_cast<float>(frac), t);
    for (int k = 0; k < kWidth; ++k)
      fit_error_ = std::max(fit_error_, std::abs(t[k] - exact(k - (kWidth / 2 - 1) - frac)));
  }
  if (fit_error_ > 1e-6) throw std::logic_error("NUFFT spreading kernel fit is not accurate enough");
}

double SpreadKernel::exact(double z) const {
  const double a = 2 * z / kWidth;
  if (std::abs(a) >= 1) return 0;
  return std::exp(beta_ * (std::sqrt(1 - a * a) - 1));
}

double SpreadKernel::fourier(double nu) const {
  // phi is even: integral of phi(z) cos(2 pi nu z) over [-w/2, w/2], composite Simpson. The
  // kernel is analytic inside and ~exp(-beta) at the ends, so 4000 intervals give ~1e-10.
  constexpr int kIntervals = 4000;
  const double a = -kWidth / 2.0, h = kWidth / static_cast<double>(kIntervals);
  double sum = 0;
  for (int i = 0; i <= kIntervals; ++i) {
    const double z = a + i * h;
    const double f = exact(z) * std::cos(2 * std::numbers::pi * nu * z);
    sum += (i == 0 || i == kIntervals) ? f : (i % 2 ? 4 * f : 2 * f);
  }
  return sum * h / 3;
}

}  // namespace rsrio::sim::detail
