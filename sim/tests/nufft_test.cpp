// The simulator's numerical building blocks against straightforward double-precision versions.
#include "nufft.hpp"

#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <vector>

#include <catch2/catch_test_macros.hpp>

using rsrio::sim::detail::InverseFft;
using rsrio::sim::detail::reduce_cycles;
using rsrio::sim::detail::sincos_2pi;
using rsrio::sim::detail::SpreadKernel;

TEST_CASE("sim: sincos_2pi is accurate over a whole turn", "[nufft]") {
  double worst = 0;
  for (int i = 0; i <= 200000; ++i) {
    const double x = -0.5 + i / 200000.0;
    float s, c;
    sincos_2pi(static_cast<float>(x), s, c);
    const double xf = static_cast<float>(x);
    worst = std::max({worst, std::abs(s - std::sin(2 * std::numbers::pi * xf)),
                      std::abs(c - std::cos(2 * std::numbers::pi * xf))});
  }
  CHECK(worst < 3e-7);
}

TEST_CASE("sim: reduce_cycles keeps the fraction of large phases", "[nufft]") {
  CHECK(std::abs(reduce_cycles(12345.25) - 0.25) < 1e-11);
  CHECK(std::abs(reduce_cycles(-7.75) - 0.25) < 1e-12);
  CHECK(std::abs(reduce_cycles(3.5)) == 0.5);
}

TEST_CASE("sim: inverse FFT equals the direct inverse DFT", "[nufft]") {
  for (int n : {2, 8, 256, 512}) {
    std::mt19937 rng(7);
    std::normal_distribution<float> g;
    std::vector<float> re(n), im(n);
    for (int i = 0; i < n; ++i) re[i] = g(rng), im[i] = g(rng);
    std::vector<std::complex<double>> direct(n);
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        direct[k] += std::complex<double>(re[j], im[j]) * std::polar(1.0, 2 * std::numbers::pi * j * k / n);
    InverseFft fft(n);
    fft.run(re.data(), im.data());
    double worst = 0;
    for (int k = 0; k < n; ++k) {
      const int at = fft.output(k);
      worst = std::max(worst, std::abs(std::complex<double>(re[at], im[at]) - direct[k]));
    }
    CHECK(worst < 1e-4 * std::sqrt(n));
  }
}

TEST_CASE("sim: fast_log is accurate", "[nufft]") {
  double worst = 0;
  for (int i = 1; i <= 100000; ++i) {
    const float x = static_cast<float>(i) * 1e-5f;
    worst = std::max(worst, std::abs(rsrio::sim::detail::fast_log(x) - std::log(double(x))));
  }
  CHECK(worst < 3e-7 * 12);  // absolute, up to |log x| = 11.5
}

TEST_CASE("sim: the spreading kernel polynomial fits the exact kernel", "[nufft]") {
  const SpreadKernel k;
  CHECK(k.fit_error() < 2e-7);
  // Its Fourier transform at 0 is its integral.
  double integral = 0;
  for (int i = 0; i < 80000; ++i) integral += k.exact(-4 + (i + 0.5) * 1e-4) * 1e-4;
  CHECK(std::abs(k.fourier(0) - integral) < 1e-9);
}
