// CFAR threshold design from a false-alarm probability, analytically (no simulation).
//
// Noise model: each cell of the range-Doppler power map is the non-coherent sum of the powers of
// `shape` independent complex Gaussian channels of equal noise power, i.e. Gamma(shape, mu)
// distributed (shape = number of virtual channels; with unequal channel gains g_v the
// Satterthwaite equivalent shape (sum g_v^2)^2 / sum g_v^4 is used). The cell under test is taken
// as independent of its training cells (the guard cells keep the window's main lobe out).
// Training cells of a windowed FFT are correlated with their neighbours; for CA the processor
// passes an effective number of cells N_eff = N^2 / sum_ij |rho_ij|^2 (rho: correlation of the
// complex cells, from the range and Doppler windows), which keeps the mean of the training sum and
// matches its variance (N_eff need not be an integer). OS assumes independent training cells.
//
// CA: detect when CUT > alpha * (sum of N training cells) / N. CUT / (CUT + sum) ~ Beta(V, N V),
//     so Pfa = 1 - I_{alpha / (N + alpha)}(V, N V) (regularised incomplete beta). For V = 1 this
//     is the textbook (1 + alpha / N)^-N.
// OS: detect when CUT > alpha * X_(k), the k-th smallest of N training cells (1-based). Pfa =
//     integral over x of Q(V, alpha x) f_k(x) with f_k the density of the k-th order statistic of
//     N Gamma(V, 1) cells (Simpson quadrature). For V = 1 this is Rohling's
//     prod_{i=0}^{k-1} (N - i) / (N - i + alpha).
// alpha for a design Pfa is found by bisection on log(alpha).
#pragma once

namespace rsrio::cfar {

/// Regularised lower / upper incomplete gamma P(a, x), Q(a, x) = 1 - P (each computed directly
/// in its tail).
double gamma_p(double a, double x);
double gamma_q(double a, double x);
/// Regularised incomplete beta I_x(a, b) and its upper tail 1 - I_x(a, b), computed directly.
double beta_i(double a, double b, double x);
double beta_i_upper(double a, double b, double x);

/// False-alarm probability of CA-CFAR with scale `alpha` on the training mean, for n_train
/// independent (or effectively independent) training cells.
double ca_pfa(double alpha, double n_train, double shape);
/// The scale that gives `pfa`.
double ca_alpha(double pfa, double n_train, double shape);

/// False-alarm probability of OS-CFAR with scale `alpha` on the k-th smallest (1-based) of n.
double os_pfa(double alpha, int n_train, int k, double shape);
double os_alpha(double pfa, int n_train, int k, double shape);
/// E[X_(k)] / E[X] for n Gamma(shape) cells: turns the k-th order statistic into a noise mean.
double os_mean_ratio(int n_train, int k, double shape);

/// k for OS-CFAR: round(rank * n), clamped to [1, n].
int os_k(double rank, int n_train);

}  // namespace rsrio::cfar
