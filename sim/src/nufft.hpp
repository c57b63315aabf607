// Numerical kernels of the radar simulator: a radix-2 FFT, a branch-free sin/cos of 2 pi x, and
// the spreading kernel of the type-1 non-uniform FFT that sums the scatterers' beat tones.
//
// Type-1 NUFFT (Dutt-Rokhlin / Greengard-Lee; the exponential-of-semicircle kernel of FINUFFT,
// Barnett et al. 2019): f[n] = sum_i c_i exp(j 2 pi x_i n), n in [-N/2, N/2), is computed by
// spreading every c_i onto a grid of G = 2 N' (N' = next power of two >= N) points with the
// kernel phi(g - G x_i), an inverse FFT of the grid, and a division by the kernel's Fourier
// transform phi_hat(n). With 8 taps and oversampling >= 2 the relative error is ~1e-7.
//
// No std::complex arithmetic in the hot loops: without -ffast-math GCC routes complex products
// through __mulsc3 (NaN/Inf recovery), which is several times slower.
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace rsrio::sim::detail {

/// sin(2 pi x) and cos(2 pi x) for |x| <= 0.5 (cycles). Absolute error below 2e-7. Branch-free,
/// so loops over it vectorise.
inline void sincos_2pi(float x, float& s, float& c) {
  // Quadrant q = round(4 x) by the float magic-number trick (exact for |4x| < 2^22).
  const float q = (4.0f * x + 12582912.0f) - 12582912.0f;
  const float r = (x - 0.25f * q) * 6.28318530717958648f;  // in [-pi/4, pi/4]
  const float r2 = r * r;
  const float sr = r * (1.0f + r2 * (-1.6666667e-1f + r2 * (8.3333333e-3f + r2 * (-1.9841270e-4f + r2 * 2.7557319e-6f))));
  const float cr = 1.0f + r2 * (-0.5f + r2 * (4.1666667e-2f + r2 * (-1.3888889e-3f + r2 * (2.4801587e-5f + r2 * -2.7557319e-7f))));
  const int iq = static_cast<int>(q) & 3;
  const bool swap = (iq & 1) != 0;
  const float s0 = swap ? cr : sr, c0 = swap ? sr : cr;
  s = (iq & 2) ? -s0 : s0;
  c = ((iq + 1) & 2) ? -c0 : c0;
}

/// x - round(x) for |x| < 2^51, in [-0.5, 0.5] (cycles reduced to one turn).
inline double reduce_cycles(double x) { return x - ((x + 6755399441055744.0) - 6755399441055744.0); }

/// In-place radix-2 inverse DFT, y[n] = sum_g b[g] exp(+j 2 pi g n / G), unnormalised, on split
/// real / imaginary arrays. Decimation in frequency: the input is in natural order, the output in
/// bit-reversed order (output() gives where y[n] ended up), which saves the permutation pass.
class InverseFft {
 public:
  explicit InverseFft(int size);
  int size() const { return n_; }
  void run(float* re, float* im) const;
  /// Position of y[n] in the arrays after run().
  int output(int n) const { return bitrev_[static_cast<std::size_t>(n)]; }

 private:
  int n_ = 0;
  std::vector<int> bitrev_;
  std::vector<float> tw_re_, tw_im_;  // stage with half-length h: exp(+j 2 pi k / (2h)) at [h + k]
};

/// log(x) for normal positive floats, absolute error < 1e-6; branch-free (vectorises).
inline float fast_log(float x) {
  const auto bits = std::bit_cast<std::int32_t>(x);
  // x = 2^e m with m in [sqrt(2)/2, sqrt(2)): take the exponent of x / (sqrt(2)/2).
  const std::int32_t shifted = bits - 0x3F3504F3;  // bit pattern of sqrt(2)/2
  const std::int32_t e = shifted >> 23;
  const float m = std::bit_cast<float>(bits - (e << 23));
  const float s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
  const float log_m = 2.0f * s * (1.0f + s2 * (0.33333333f + s2 * (0.2f + s2 * (0.14285714f + s2 * 0.11111111f))));
  return static_cast<float>(e) * 0.69314718f + log_m;
}

/// The exponential-of-semicircle kernel phi(z) = exp(beta (sqrt(1 - (2 z / w)^2) - 1)), |z| <= w/2,
/// with w = kWidth taps; fitted per tap by a polynomial in the fractional grid offset so that
/// spreading costs a few fused multiply-adds, not exp() and sqrt().
class SpreadKernel {
 public:
  static constexpr int kWidth = 8;
  static constexpr int kDegree = 11;

  SpreadKernel();
  /// Tap values phi(k - (kWidth/2 - 1) - frac), k = 0..kWidth-1, for frac in [0, 1): the weights
  /// of grid points floor(xi) - 3 ... floor(xi) + 4 for a tone at grid position xi.
  void taps(float frac, float* out) const {
    const float s = 2.0f * frac - 1.0f;
    for (int k = 0; k < kWidth; ++k) out[k] = coef_[kDegree * kWidth + k];
    for (int d = kDegree - 1; d >= 0; --d)
      for (int k = 0; k < kWidth; ++k) out[k] = out[k] * s + coef_[d * kWidth + k];
  }
  /// The polynomial coefficients, [degree][tap], for Horner in s = 2 frac - 1.
  const float* coefficients() const { return coef_.data(); }
  double exact(double z) const;
  /// Its Fourier transform at frequency nu (cycles per grid step): integral phi(z) exp(j 2 pi z nu).
  double fourier(double nu) const;
  /// Largest error of taps() against exact() (checked once at construction: it throws if the
  /// fit is worse than 1e-6).
  double fit_error() const { return fit_error_; }

 private:
  double beta_ = 0;
  std::array<float, (kDegree + 1) * kWidth> coef_{};
  double fit_error_ = 0;
};

}  // namespace rsrio::sim::detail
