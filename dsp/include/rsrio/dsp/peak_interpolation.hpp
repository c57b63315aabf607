// Sub-bin position of a spectral peak from the powers of its bin and the two beside it.
//
// The log-parabola (Gaussian) fit through three bins is exact only for a Gaussian main lobe. On
// a windowed FFT it is biased by a fraction of a bin that depends on where the tone falls: for
// the DSP's 32-loop Hann Doppler window up to +-0.02 bins, pushing every estimate towards the
// middle between two bins. The bias is not noise: a walk at one speed puts most of its static
// returns at similar fractions of a bin, and on sequence 1 (0.42 m/s, 3.01 Doppler bins) the
// returns 10-30 deg off the direction of travel came out 0.4-1.8 % slow, the ego-velocity 0.4 %
// (rio/RESULTS.md). The fix is the same fit, calibrated: the fit's result for a single tone at
// every true offset is computed once from the FFT's own input taps (window, zero padding, gaps of
// a sparse aperture), and a measured fit is mapped back through that table. A single tone then
// comes out where it is, whatever the window; two tones in one main lobe do not, with either fit.
#pragma once

#include <span>
#include <vector>

namespace rsrio {

class PeakInterpolator {
 public:
  /// The plain Gaussian fit (no calibration).
  PeakInterpolator() = default;
  /// For an FFT of fft_size points whose input position positions[i] carries taps[i] (the
  /// window; positions not listed are zero). Throws std::invalid_argument for sizes that do not
  /// match or a position outside the FFT. The table runs outwards from the bin as far as the fit
  /// of a single tone rises strictly with its offset (all of -0.5 .. 0.5 for the windows of
  /// range and Doppler; to +-0.49 for the cascade's azimuth, whose main lobe is under three bins
  /// wide); offsets beyond are clamped to its ends. If it does not reach +-0.45 (a main lobe
  /// hardly wider than a bin), this is the plain fit (calibrated() false).
  PeakInterpolator(std::span<const double> taps, std::span<const int> positions, int fft_size);
  /// Window taps at positions 0 .. taps.size() - 1 (zero padded to fft_size).
  PeakInterpolator(std::span<const double> taps, int fft_size);

  /// Offset in bins (within -0.5 .. 0.5) of the peak from the centre bin, from the powers (or
  /// magnitudes: the fit is the same) of the bins left of, at and right of it; 0 when the centre
  /// is not a local maximum or a value is not positive.
  float offset(float left, float centre, float right) const;

  bool calibrated() const { return !fit_.empty(); }
  /// The true offsets the table covers (calibrated only): -0.5 .. 0.5 but for narrow main lobes.
  double table_low() const;
  double table_high() const;

 private:
  int first_ = 0;            // fit_[i] is the fit at true offset -0.5 + (first_ + i) / 1024
  std::vector<double> fit_;  // increasing
};

/// The log-parabola through (-1, log left), (0, log centre), (1, log right): its vertex, not
/// clamped; NaN when the centre is not a local maximum or a value is not positive.
double gaussian_fit(double left, double centre, double right);

}  // namespace rsrio
