// The radar simulator's inner loops as plain functions over raw arrays (so that GCC vectorises
// them), compiled twice on x86-64: for AVX2 and for the baseline, picked at load time by the
// CPU (GCC target_clones). Both versions do the same IEEE operations in the same order (no FMA
// contraction in ISO C++ mode, no reductions), so their results are bit-identical.
#pragma once

#include <cstddef>
#include <cstdint>

namespace rsrio::sim::detail {

/// Inputs of one chirp's geometry pass: scatterers at the frame's middle (world), the radar at
/// the chirp's reference time, the waveform.
struct GeometryInput {
  std::size_t count = 0;
  const double *px, *py, *pz, *vx, *vy, *vz, *ax, *ay, *az;  // scatterers at t_mid
  const float *amp_re, *amp_im;                              // amplitude without 1/R^2
  double dt = 0;                                             // chirp time - t_mid
  double radar_pos[3], radar_vel[3];                         // world
  double radar_y[3], radar_z[3];                             // radar y and z axes in the world
  double slope = 0, fc = 0, inv_fs = 0;
  double tx_azimuth = 0, tx_elevation = 0;                   // TX position x element spacing
};

/// Outputs per scatterer: phase at the reference sample without the RX part (cycles), tone
/// frequency (cycles per sample), array direction cosines scaled for the echo's frequency, and
/// the amplitude with 1/R^2.
struct GeometryOutput {
  double *psi, *x, *uy, *uz;
  float *amp_re, *amp_im;
};

void chirp_geometry(const GeometryInput& in, const GeometryOutput& out);

/// The NUFFT spreading of every scatterer of one chirp: per scatterer the RX phasors
/// amp exp(j 2 pi (psi - (rx_az uy + rx_el uz))), spread with the kernel's taps around grid
/// position G x onto each RX row of the padded grid (rows of `stride` floats, kernel width 8).
struct SpreadInput {
  std::size_t count = 0;
  const double *psi, *x, *uy, *uz;
  const float *amp_re, *amp_im;
  int n_rx = 0;
  const double *rx_azimuth, *rx_elevation;  // x element spacing
  const float* kernel_coefficients;         // [degree + 1][8], Horner in s = 2 frac - 1
  int kernel_degree = 0;
  int grid_size = 0;
  std::size_t stride = 0;
  float *scratch_re, *scratch_im;           // n_rx floats each
};
void spread_scatterers(const SpreadInput& in, float* grid_re, float* grid_im);

/// Adds a tone (one phasor per RX) onto the grid: the TX-RX leakage.
void spread_tone(double x, const float* c_re, const float* c_im, int n_rx, const float* kernel_coefficients,
                 int kernel_degree, int grid_size, std::size_t stride, float* grid_re, float* grid_im);

/// Complex Gaussian noise from raw random bits (one 64-bit draw per sample), added to
/// interleaved complex samples.
void add_gaussian_noise(const std::uint64_t* bits, std::size_t count, float sigma, float* samples);

/// In-place decimation-in-frequency radix-2 butterflies (see InverseFft).
void fft_dif(int size, float* re, float* im, const float* tw_re, const float* tw_im);

}  // namespace rsrio::sim::detail
