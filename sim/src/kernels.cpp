#include "kernels.hpp"

#include <cmath>
#include <cstring>

#include "nufft.hpp"

// One AVX2 and one baseline version of each function on x86-64 with GCC; the dynamic loader
// picks by CPU. Sanitizer builds keep one version (their runtimes and ifunc resolvers do not mix
// well, and speed does not matter there).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(RSRIO_SIM_NO_CLONES)
#define RSRIO_SIM_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define RSRIO_SIM_CLONES
#endif

namespace rsrio::sim::detail {

namespace {

constexpr double kC = 299'792'458.0;
constexpr int kTaps = 8;

// Kernel taps for fractional grid offset frac (Horner, all taps at once).
inline void kernel_taps(const float* __restrict coef, int degree, float frac, float* __restrict taps) {
  const float s = 2.0f * frac - 1.0f;
  for (int k = 0; k < kTaps; ++k) taps[k] = coef[degree * kTaps + k];
  for (int d = degree - 1; d >= 0; --d)
    for (int k = 0; k < kTaps; ++k) taps[k] = taps[k] * s + coef[d * kTaps + k];
}

inline void spread_one(double x, const float* __restrict c_re, const float* __restrict c_im, int n_rx,
                       const float* __restrict coef, int degree, int grid_size, std::size_t stride,
                       float* __restrict grid_re, float* __restrict grid_im) {
  double xi = (x - std::floor(x)) * grid_size;
  if (xi >= grid_size) xi -= grid_size;  // x a hair below an integer rounds up to it
  const double cell = std::floor(xi);
  float taps[kTaps];
  kernel_taps(coef, degree, static_cast<float>(xi - cell), taps);
  // Taps at grid points floor(xi) - 3 ... floor(xi) + 4; the padded row starts at grid point -4.
  const std::size_t first = static_cast<std::size_t>(static_cast<int>(cell) - (kTaps / 2 - 1) + kTaps / 2);
  // Eight taps are one 8-float vector: GCC's vector extension (AVX: one register; baseline: two
  // SSE registers). Left to itself, GCC vectorises across the RX rows instead, with gathers.
  using v8f = float __attribute__((vector_size(32)));
  static_assert(kTaps == 8);
  v8f w;
  std::memcpy(&w, taps, sizeof w);
  for (int r = 0; r < n_rx; ++r) {
    float* gr = grid_re + static_cast<std::size_t>(r) * stride + first;
    float* gi = grid_im + static_cast<std::size_t>(r) * stride + first;
    v8f a, b;
    std::memcpy(&a, gr, sizeof a);
    std::memcpy(&b, gi, sizeof b);
    a += c_re[r] * w;
    b += c_im[r] * w;
    std::memcpy(gr, &a, sizeof a);
    std::memcpy(gi, &b, sizeof b);
  }
}

}  // namespace

namespace {

// The loop with every array a restrict parameter: restrict on local copies of struct members is
// not enough for GCC to drop its run-time alias checks (and it gives up above ten of them).
[[gnu::always_inline]] inline void geometry_loop(
    std::size_t n, const double* __restrict p_x, const double* __restrict p_y, const double* __restrict p_z,
    const double* __restrict v_x, const double* __restrict v_y, const double* __restrict v_z,
    const double* __restrict a_x, const double* __restrict a_y, const double* __restrict a_z,
    const float* __restrict b_re, const float* __restrict b_im, double* __restrict o_psi, double* __restrict o_x,
    double* __restrict o_uy, double* __restrict o_uz, float* __restrict o_re, float* __restrict o_im,
    const GeometryInput& in) {
  const double dt = in.dt, half_dt2 = 0.5 * in.dt * in.dt;
  const double rx0 = in.radar_pos[0], ry0 = in.radar_pos[1], rz0 = in.radar_pos[2];
  const double rvx = in.radar_vel[0], rvy = in.radar_vel[1], rvz = in.radar_vel[2];
  const double eyx = in.radar_y[0], eyy = in.radar_y[1], eyz = in.radar_y[2];
  const double ezx = in.radar_z[0], ezy = in.radar_z[1], ezz = in.radar_z[2];
  const double s = in.slope, f = in.fc, inv_fs = in.inv_fs, tx_a = in.tx_azimuth, tx_e = in.tx_elevation;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = p_x[i] + v_x[i] * dt + a_x[i] * half_dt2 - rx0;
    const double dy = p_y[i] + v_y[i] * dt + a_y[i] * half_dt2 - ry0;
    const double dz = p_z[i] + v_z[i] * dt + a_z[i] * half_dt2 - rz0;
    const double r = std::sqrt(dx * dx + dy * dy + dz * dz), inv_r = 1 / r;
    const double ux = dx * inv_r, uy = dy * inv_r, uz = dz * inv_r;
    const double rdot =
        ux * (v_x[i] + a_x[i] * dt - rvx) + uy * (v_y[i] + a_y[i] * dt - rvy) + uz * (v_z[i] + a_z[i] * dt - rvz);
    const double tau = 2 * r / kC, tau_dot = 2 * rdot / kC;
    // The echo left the radar tau earlier, at frequency fc - S tau: the array phase scales so.
    const double scale = 1 - s * tau / f;
    const double uyr = scale * (ux * eyx + uy * eyy + uz * eyz), uzr = scale * (ux * ezx + uy * ezy + uz * ezz);
    o_psi[i] = f * tau - 0.5 * s * tau * tau - (tx_a * uyr + tx_e * uzr);
    o_x[i] = (s * tau * (1 - tau_dot) + f * tau_dot) * inv_fs;
    o_uy[i] = uyr;
    o_uz[i] = uzr;
    const float inv_r2 = static_cast<float>(inv_r * inv_r);
    o_re[i] = b_re[i] * inv_r2;
    o_im[i] = b_im[i] * inv_r2;
  }
}

}  // namespace

RSRIO_SIM_CLONES
void chirp_geometry(const GeometryInput& in, const GeometryOutput& out) {
  geometry_loop(in.count, in.px, in.py, in.pz, in.vx, in.vy, in.vz, in.ax, in.ay, in.az, in.amp_re, in.amp_im, out.psi,
                out.x, out.uy, out.uz, out.amp_re, out.amp_im, in);
}

RSRIO_SIM_CLONES
void spread_scatterers(const SpreadInput& in, float* grid_re, float* grid_im) {
  // One sin/cos per RX, vectorised across the RX channels. (Stepping the phasor along runs of
  // consecutive antenna positions needs fewer sin/cos but was measured 12 % slower: the chained
  // products do not vectorise.)
  const int nrx = in.n_rx;
  const double* __restrict rxa = in.rx_azimuth;
  const double* __restrict rxe = in.rx_elevation;
  float* __restrict cre = in.scratch_re;
  float* __restrict cim = in.scratch_im;
  float ph[64];  // n_rx <= 64 (checked by the caller)
  for (std::size_t i = 0; i < in.count; ++i) {
    const double psi = in.psi[i], uy = in.uy[i], uz = in.uz[i];
    for (int r = 0; r < nrx; ++r) ph[r] = static_cast<float>(reduce_cycles(psi - (rxa[r] * uy + rxe[r] * uz)));
    const float ar = in.amp_re[i], ai = in.amp_im[i];
    for (int r = 0; r < nrx; ++r) {
      float sn, cs;
      sincos_2pi(ph[r], sn, cs);
      cre[r] = ar * cs - ai * sn;
      cim[r] = ar * sn + ai * cs;
    }
    spread_one(in.x[i], cre, cim, nrx, in.kernel_coefficients, in.kernel_degree, in.grid_size, in.stride, grid_re,
               grid_im);
  }
}

RSRIO_SIM_CLONES
void spread_tone(double x, const float* c_re, const float* c_im, int n_rx, const float* kernel_coefficients,
                 int kernel_degree, int grid_size, std::size_t stride, float* grid_re, float* grid_im) {
  spread_one(x, c_re, c_im, n_rx, kernel_coefficients, kernel_degree, grid_size, stride, grid_re, grid_im);
}

RSRIO_SIM_CLONES
void add_gaussian_noise(const std::uint64_t* __restrict bits, std::size_t count, float sigma, float* __restrict o) {
  for (std::size_t i = 0; i < count; ++i) {
    // Box-Muller on one 64-bit draw: |n|^2 = sigma^2 Exp(1), uniform phase. 24-bit uniforms: the
    // magnitude's tail is cut at 4.1 sigma (probability 6e-8).
    const auto hi = static_cast<std::int32_t>(bits[i] >> 40), lo = static_cast<std::int32_t>(bits[i] & 0xFFFFFFu);
    const float u1 = static_cast<float>(hi + 1) * 0x1.0p-24f;  // (0, 1]
    const float u2 = static_cast<float>(lo) * 0x1.0p-24f - 0.5f;
    const float mag = sigma * std::sqrt(-fast_log(u1));
    float sn, cs;
    sincos_2pi(u2, sn, cs);
    o[2 * i] += mag * cs;
    o[2 * i + 1] += mag * sn;
  }
}

RSRIO_SIM_CLONES
void fft_dif(int size, float* __restrict re, float* __restrict im, const float* __restrict tw_re,
             const float* __restrict tw_im) {
  // Butterflies (a, b) -> (a + b, (a - b) w), halves shrinking; each inner loop runs over
  // contiguous memory and contiguous twiddles.
  for (int h = size / 2; h >= 1; h /= 2) {
    const float* __restrict wr = tw_re + h;
    const float* __restrict wi = tw_im + h;
    for (int start = 0; start < size; start += 2 * h) {
      float* __restrict ar = re + start;
      float* __restrict ai = im + start;
      float* __restrict br = ar + h;
      float* __restrict bi = ai + h;
      for (int k = 0; k < h; ++k) {
        const float xr = ar[k], xi = ai[k], yr = br[k], yi = bi[k];
        const float dr = xr - yr, di = xi - yi;
        ar[k] = xr + yr;
        ai[k] = xi + yi;
        br[k] = dr * wr[k] - di * wi[k];
        bi[k] = dr * wi[k] + di * wr[k];
      }
    }
  }
}

}  // namespace rsrio::sim::detail
