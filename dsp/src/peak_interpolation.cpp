#include "rsrio/dsp/peak_interpolation.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>

namespace rsrio {

namespace {

constexpr int kSteps = 1024;  // table resolution: 1/1024 bin, linear in between (error < 1e-5 bin)
// The table must reach at least 0.45 bins each side; a narrower one (a main lobe hardly wider
// than a bin) is no calibration: the plain fit is used.
constexpr int kMinHalfSpan = kSteps * 45 / 100;

}  // namespace

double gaussian_fit(double left, double centre, double right) {
  if (!(left > 0 && centre > 0 && right > 0) || centre < left || centre < right)
    return std::numeric_limits<double>::quiet_NaN();
  const double l = std::log(left), c = std::log(centre), r = std::log(right);
  const double den = l - 2 * c + r;
  if (!(den < 0)) return std::numeric_limits<double>::quiet_NaN();
  return 0.5 * (l - r) / den;
}

namespace {

// The Gaussian fit's offset for a single tone at true offset delta: the powers of bins -1, 0, 1
// are |sum_i w_i exp(-j 2 pi (m - delta) p_i / N)|^2.
double gaussian_fit_of_tone(std::span<const double> taps, std::span<const int> positions, int fft_size,
                            double delta) {
  double power[3];
  for (int m = -1; m <= 1; ++m) {
    std::complex<double> acc{};
    for (std::size_t i = 0; i < taps.size(); ++i)
      acc += taps[i] * std::polar(1.0, -2 * std::numbers::pi * (m - delta) * positions[i] / fft_size);
    power[m + 1] = std::norm(acc);
  }
  return gaussian_fit(power[0], power[1], power[2]);
}

}  // namespace

PeakInterpolator::PeakInterpolator(std::span<const double> taps, std::span<const int> positions, int fft_size) {
  if (taps.size() != positions.size() || taps.empty())
    throw std::invalid_argument("PeakInterpolator: " + std::to_string(taps.size()) + " taps for " +
                                std::to_string(positions.size()) + " positions");
  for (int p : positions)
    if (p < 0 || p >= fft_size)
      throw std::invalid_argument("PeakInterpolator: position " + std::to_string(p) + " outside the FFT of " +
                                  std::to_string(fft_size));
  std::vector<double> fit(kSteps + 1);
  for (int i = 0; i <= kSteps; ++i)
    fit[static_cast<std::size_t>(i)] = gaussian_fit_of_tone(taps, positions, fft_size, -0.5 + double(i) / kSteps);
  // Invertible where the fit rises strictly with the offset (NaN compares false), outwards from
  // the bin. A main lobe narrower than three bins puts the far neighbour of a tone near +-0.5
  // past the first null (the cascade's 86 elements in 128 bins: nulls 1.49 bins out), where the
  // fit turns; beyond that the table stops and offsets are clamped to its ends.
  const int mid = kSteps / 2;
  int lo = mid, hi = mid;
  while (lo > 0 && fit[static_cast<std::size_t>(lo - 1)] < fit[static_cast<std::size_t>(lo)]) --lo;
  while (hi < kSteps && fit[static_cast<std::size_t>(hi + 1)] > fit[static_cast<std::size_t>(hi)]) ++hi;
  if (!std::isfinite(fit[static_cast<std::size_t>(mid)]) || mid - lo < kMinHalfSpan || hi - mid < kMinHalfSpan) return;
  first_ = lo;
  fit_.assign(fit.begin() + lo, fit.begin() + hi + 1);
}

PeakInterpolator::PeakInterpolator(std::span<const double> taps, int fft_size)
    : PeakInterpolator(taps,
                       [&] {
                         std::vector<int> p(taps.size());
                         std::iota(p.begin(), p.end(), 0);
                         return p;
                       }(),
                       fft_size) {}

double PeakInterpolator::table_low() const { return -0.5 + double(first_) / kSteps; }
double PeakInterpolator::table_high() const {
  return -0.5 + double(first_ + static_cast<int>(fit_.size()) - 1) / kSteps;
}

float PeakInterpolator::offset(float left, float centre, float right) const {
  const double q = gaussian_fit(left, centre, right);
  if (!std::isfinite(q)) return 0.f;
  if (fit_.empty()) return static_cast<float>(std::clamp(q, -0.5, 0.5));
  const auto at = [&](double i) { return static_cast<float>(-0.5 + (first_ + i) / kSteps); };
  if (q <= fit_.front()) return at(0);
  if (q >= fit_.back()) return at(static_cast<double>(fit_.size() - 1));
  const auto hi = std::upper_bound(fit_.begin(), fit_.end(), q);
  const std::size_t i = static_cast<std::size_t>(hi - fit_.begin());  // fit_[i - 1] <= q < fit_[i]
  const double a = fit_[i - 1], b = fit_[i];
  return at(static_cast<double>(i) - 1 + (q - a) / (b - a));
}

}  // namespace rsrio
