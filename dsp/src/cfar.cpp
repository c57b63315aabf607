#include "rsrio/dsp/cfar.hpp"

#include <math.h>  // lgamma_r

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace rsrio::cfar {

namespace {

constexpr double kEps = 1e-15;

// log Gamma(x) without std::lgamma, which writes the global signgam (a data race when processors
// are made on several threads): glibc's reentrant lgamma_r.
double log_gamma(double x) {
  int sign = 0;
  return ::lgamma_r(x, &sign);
}
constexpr double kTiny = 1e-300;

// Series for P(a, x), x < a + 1 (Numerical Recipes gser).
double gamma_series(double a, double x) {
  if (x <= 0) return 0.0;
  double ap = a, sum = 1.0 / a, del = sum;
  for (int n = 0; n < 100000; ++n) {
    ap += 1;
    del *= x / ap;
    sum += del;
    if (std::fabs(del) < std::fabs(sum) * kEps) break;
  }
  return sum * std::exp(-x + a * std::log(x) - log_gamma(a));
}

// Continued fraction for Q(a, x), x >= a + 1 (modified Lentz, NR gcf).
double gamma_cf(double a, double x) {
  double b = x + 1 - a, c = 1 / kTiny, d = 1 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1) < kEps) break;
  }
  return std::exp(-x + a * std::log(x) - log_gamma(a)) * h;
}

// Continued fraction of the incomplete beta (NR betacf).
double beta_cf(double a, double b, double x) {
  const double qab = a + b, qap = a + 1, qam = a - 1;
  double c = 1, d = 1 - qab * x / qap;
  if (std::fabs(d) < kTiny) d = kTiny;
  d = 1 / d;
  double h = d;
  for (int m = 1; m < 100000; ++m) {
    const int m2 = 2 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1 + aa * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1 + aa / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1 + aa * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1 + aa / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1) < kEps) break;
  }
  return h;
}

// Both tails of I_x(a, b); the one that is small is computed without cancellation.
void beta_tails(double a, double b, double x, double& lower, double& upper) {
  if (x <= 0) {
    lower = 0;
    upper = 1;
    return;
  }
  if (x >= 1) {
    lower = 1;
    upper = 0;
    return;
  }
  const double front =
      std::exp(log_gamma(a + b) - log_gamma(a) - log_gamma(b) + a * std::log(x) + b * std::log1p(-x));
  if (x < (a + 1) / (a + b + 2)) {
    lower = front * beta_cf(a, b, x) / a;
    upper = 1 - lower;
  } else {
    upper = front * beta_cf(b, a, 1 - x) / b;
    lower = 1 - upper;
  }
}

// Bisection on log(alpha) for a decreasing pfa(alpha).
template <typename F>
double solve_alpha(double pfa, F&& pfa_of) {
  double lo = std::log(1e-6), hi = std::log(1e9);
  if (pfa_of(std::exp(hi)) > pfa)
    throw std::domain_error("CFAR design: Pfa not reachable (too few training cells)");
  for (int i = 0; i < 64; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (pfa_of(std::exp(mid)) > pfa)
      lo = mid;
    else
      hi = mid;
    if (hi - lo < 1e-10) break;
  }
  return std::exp(0.5 * (lo + hi));
}

// Quadrature grid for the k-th order statistic of n Gamma(shape, 1) cells: the points x_i, the
// Simpson weights times the density f_k(x_i).
struct OrderStatGrid {
  std::vector<double> x, w;
};

OrderStatGrid order_stat_grid(int n, int k, double shape) {
  constexpr int kIntervals = 2000;
  const double sd = std::sqrt(shape);
  const double lo = std::max(0.0, shape - 14 * sd - 10);
  const double hi = shape + 16 * sd + 40;
  const double h = (hi - lo) / kIntervals;
  const double log_coef =
      std::log(static_cast<double>(k)) + log_gamma(n + 1.0) - log_gamma(k + 1.0) - log_gamma(n - k + 1.0);
  OrderStatGrid g;
  g.x.resize(kIntervals + 1);
  g.w.resize(kIntervals + 1);
  for (int i = 0; i <= kIntervals; ++i) {
    const double x = lo + i * h;
    g.x[i] = x;
    double f = 0;
    if (x > 0) {
      const double p = gamma_p(shape, x), q = gamma_q(shape, x);
      if (p > 0 && q > 0) {
        const double log_pdf = (shape - 1) * std::log(x) - x - log_gamma(shape);
        f = std::exp(log_coef + (k - 1) * std::log(p) + (n - k) * std::log(q) + log_pdf);
      }
    }
    const double simpson = (i == 0 || i == kIntervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    g.w[i] = f * simpson * h / 3;
  }
  return g;
}

void check(double n_train, double shape) {
  if (!(n_train >= 1)) throw std::invalid_argument("CFAR design: at least one training cell");
  if (!(shape > 0)) throw std::invalid_argument("CFAR design: shape must be positive");
}

}  // namespace

double gamma_p(double a, double x) {
  if (x <= 0) return 0;
  return x < a + 1 ? gamma_series(a, x) : 1 - gamma_cf(a, x);
}

double gamma_q(double a, double x) {
  if (x <= 0) return 1;
  return x < a + 1 ? 1 - gamma_series(a, x) : gamma_cf(a, x);
}

double beta_i(double a, double b, double x) {
  double lo, up;
  beta_tails(a, b, x, lo, up);
  return lo;
}

double beta_i_upper(double a, double b, double x) {
  double lo, up;
  beta_tails(a, b, x, lo, up);
  return up;
}

double ca_pfa(double alpha, double n_train, double shape) {
  check(n_train, shape);
  const double n = n_train;
  return beta_i_upper(shape, n * shape, alpha / (n + alpha));
}

double ca_alpha(double pfa, double n_train, double shape) {
  check(n_train, shape);
  return solve_alpha(pfa, [&](double a) { return ca_pfa(a, n_train, shape); });
}

int os_k(double rank, int n_train) {
  return std::clamp(static_cast<int>(std::lround(rank * n_train)), 1, std::max(1, n_train));
}

double os_pfa(double alpha, int n_train, int k, double shape) {
  check(n_train, shape);
  if (k < 1 || k > n_train) throw std::invalid_argument("OS-CFAR: k must be in [1, n]");
  const OrderStatGrid g = order_stat_grid(n_train, k, shape);
  double s = 0;
  for (std::size_t i = 0; i < g.x.size(); ++i)
    if (g.w[i] > 0) s += g.w[i] * gamma_q(shape, alpha * g.x[i]);
  return s;
}

double os_alpha(double pfa, int n_train, int k, double shape) {
  check(n_train, shape);
  if (k < 1 || k > n_train) throw std::invalid_argument("OS-CFAR: k must be in [1, n]");
  const OrderStatGrid g = order_stat_grid(n_train, k, shape);
  return solve_alpha(pfa, [&](double a) {
    double s = 0;
    for (std::size_t i = 0; i < g.x.size(); ++i)
      if (g.w[i] > 0) s += g.w[i] * gamma_q(shape, a * g.x[i]);
    return s;
  });
}

double os_mean_ratio(int n_train, int k, double shape) {
  check(n_train, shape);
  const OrderStatGrid g = order_stat_grid(n_train, k, shape);
  double m = 0;
  for (std::size_t i = 0; i < g.x.size(); ++i) m += g.w[i] * g.x[i];
  return m / shape;
}

}  // namespace rsrio::cfar
