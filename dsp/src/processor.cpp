#include "rsrio/dsp/processor.hpp"

#include <fftw3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>

#include "rsrio/common/options.hpp"
#include "rsrio/dsp/cfar.hpp"
#include "rsrio/dsp/fftw.hpp"
#include "rsrio/dsp/peak_interpolation.hpp"
#include "rsrio/dsp/window.hpp"

namespace rsrio {

namespace {

using cf = std::complex<float>;

// Plain complex arithmetic: std::complex's operator* carries NaN/Inf recovery (__mulsc3) that
// stops vectorisation; our data is finite.
inline cf cmul(cf a, cf b) {
  return {a.real() * b.real() - a.imag() * b.imag(), a.real() * b.imag() + a.imag() * b.real()};
}
inline float power(cf a) {
  return a.real() * a.real() + a.imag() * a.imag();
}

constexpr int kMaxAnglePeaks = 16;
constexpr double kElevationStep = 0.005;

struct CfarDesign {
  int count = 0;
  double n_eff = 0;  // CA: effective number of independent training cells
  int k = 0;
  double alpha = 0;
  double mean_ratio = 1;  // OS: E[X_(k)] / E[X]
};

struct ElevationRow {
  int dq = 0;                  // elevation offset from the lowest row (position units)
  std::vector<int> elevated;   // virtual channels in this row
  std::vector<int> reference;  // the filled-array channel at the same azimuth position
  std::vector<int> position;   // their azimuth position
};

}  // namespace

struct DspProcessor::Impl {
  RadarConfig config;
  DspOptions opt;
  RadarDerived der;
  DspGrids grids;
  int L = 0, S = 0, R = 0, V = 0, Ns = 0, Nr = 0, Nd = 0, Na = 0;
  int doppler_climb = 0;  // the Doppler window's main lobe, 2 resolution cells, in bins (make_points)

  std::vector<cf> range_w;              // [V][Ns]: window / sum * calibration
  std::vector<float> doppler_w;         // [L]: window / sum * (-1)^l
  std::vector<cf> tdm;                  // [S][Nd]: TDM compensation (ones when off)
  std::vector<cf> angle_g;              // [element][Nd]: angle window / sum * (-1)^pos * tdm
  double angle_w2 = 0;                  // sum of the squared unit-sum angle window
  std::vector<int> el_pos, el_chan;     // filled array
  std::vector<unsigned char> az_valid;  // |sin| <= 1
  // Sub-bin peaks of points (make_points), each for its FFT's taps (DspOptions::interpolation).
  PeakInterpolator range_peak, doppler_peak, azimuth_peak;
  bool sub_bin = true;  // interpolation != "none", resolved once, not per point

  AlignedBuffer<cf> rin, rout;          // [N_d][N_r]: one channel's chirps (rows >= L stay zero)
  AlignedBuffer<cf> mean_in, mean_out;  // the channel's mean chirp and its range FFT (clutter)
  std::vector<cf> doppler_window_dft;   // [N_d]: DFT of doppler_w (clutter removal)
  AlignedBuffer<cf> chan, abuf, obuf;
  std::vector<float> rad, ra, rd;
  FftPlan range_plan, mean_plan, doppler_plan, angle_plan;

  // CFAR
  double shape = 1;
  int r_lo = 0, r_hi = 0;
  std::vector<CfarDesign> row_design;        // per range bin: 2d window or range pass
  CfarDesign doppler_design;                 // dual pass, Doppler pass
  int pad = 0;                               // Doppler padding of rdx (guard + training)
  std::vector<float> rdx;                    // [range][pad + Nd + pad]: RD with circular Doppler padding
  std::vector<double> cum_outer, cum_guard;  // [range + 1][Nd]: prefix sums over range of the
                                             // Doppler window sums (2d CA)
  std::vector<float> os_scratch;
  std::vector<DspDetection> dets;
  std::vector<DspPoint> points;

  // elevation
  std::vector<ElevationRow> rows;
  std::vector<double> uz_grid;
  std::vector<std::complex<double>> elev_table;  // [row][grid]: exp(+j 2 pi d dq uz)
  std::vector<std::complex<double>> row_z;

  DspResult result;
  Impl(const RadarConfig& c, const DspOptions& o);
  void setup_cfar();
  void setup_elevation();
  void run_ffts(const AdcCube& cube);
  void run_cfar();
  void make_points();
  float elevation_uz(int r, int d, double uy, bool& measured);
  float rad_at(int r, int a, int d) const { return rad[(static_cast<std::size_t>(r) * Nd + d) * Na + a]; }
};

DspProcessor::Impl::Impl(const RadarConfig& c, const DspOptions& o) : config(c), opt(o) {
  validate(opt, "<dsp options>");
  der = derive(config);
  L = config.loops;
  S = der.num_tx;
  R = der.num_rx;
  V = der.num_virtual;
  Ns = config.chirp.samples_per_chirp;
  Nr = der.range_fft_size;
  Nd = der.doppler_fft_size;
  Na = config.angle_fft_size;
  if (L < 1 || S < 1 || R < 1 || Ns < 1 || Na < 1)
    throw std::invalid_argument("DSP: empty radar configuration");
  doppler_climb = (2 * Nd + L - 1) / L;
  const unsigned flags = fftw_planner_flags(opt.fft_planning);
  const double pi = std::numbers::pi;
  const double dsp_d = der.element_spacing_wavelengths;

  // ---- grids
  grids.range_bins = Nr;
  grids.doppler_bins = Nd;
  grids.azimuth_bins = Na;
  grids.range_bin_m = der.range_bin_size_m;
  grids.velocity_bin_mps = der.velocity_bin_size_mps;
  grids.azimuth_sin_bin = 1.0 / (Na * dsp_d);
  grids.azimuth_unambiguous_sin = 1.0 / dsp_d - 1.0;
  grids.element_spacing_wavelengths = dsp_d;
  grids.wavelength_m = der.wavelength_m;
  for (int r = 0; r < Nr; ++r) grids.range_m.push_back(r * der.range_bin_size_m);
  for (int d = 0; d < Nd; ++d) grids.doppler_mps.push_back((d - Nd / 2) * der.velocity_bin_size_mps);
  az_valid.assign(Na, 0);
  for (int a = 0; a < Na; ++a) {
    const double s = (a - Na / 2) * grids.azimuth_sin_bin;
    grids.azimuth_sin.push_back(s);
    grids.azimuth_deg.push_back(std::fabs(s) <= 1.0 ? std::asin(s) * 180.0 / pi
                                                    : std::numeric_limits<double>::quiet_NaN());
    az_valid[a] = std::fabs(s) <= 1.0;
  }

  // ---- filled azimuth array: unique positions at the lowest elevation row
  int min_el = std::numeric_limits<int>::max(), min_az = std::numeric_limits<int>::max(),
      max_az = std::numeric_limits<int>::min();
  for (const auto& vc : der.virtual_channels) min_el = std::min(min_el, vc.elevation);
  std::map<int, int> first_at;  // azimuth position -> virtual channel
  for (int v = 0; v < V; ++v) {
    const auto& vc = der.virtual_channels[v];
    if (vc.elevation != min_el) continue;
    first_at.emplace(vc.azimuth, v);
    min_az = std::min(min_az, vc.azimuth);
    max_az = std::max(max_az, vc.azimuth);
  }
  if (max_az - min_az + 1 > Na)
    throw std::invalid_argument("DSP: the azimuth array spans " + std::to_string(max_az - min_az + 1) +
                                " positions, more than angle_fft_size " + std::to_string(Na));
  // Positions count to the radar's left (+y) and the spatial phase is -2 pi d p u_y: the array
  // enters the FFT mirrored (index max - p), so that bin a -> u_y = (a - N/2) / (N d).
  for (const auto& [pos, v] : first_at) {
    el_pos.push_back(max_az - pos);
    el_chan.push_back(v);
  }
  grids.azimuth_positions = el_pos;
  grids.azimuth_channels = el_chan;

  // ---- windows and calibration
  const std::vector<double> wr = make_window(opt.range_window, Ns);
  double wr_sum = 0;
  for (double w : wr) wr_sum += w;
  const bool cal_gain = opt.calibration && !config.calibration.gain.empty();
  const bool cal_freq = opt.calibration && !config.calibration.frequency_offset_hz.empty();
  const double fs = config.chirp.adc_sample_rate_ksps * 1e3;
  range_w.resize(static_cast<std::size_t>(V) * Ns);
  double g2 = 0, g4 = 0;
  for (int v = 0; v < V; ++v) {
    const auto& vc = der.virtual_channels[v];
    const std::size_t idx = static_cast<std::size_t>(vc.tx) * R + vc.rx;
    const std::complex<double> gain = cal_gain ? config.calibration.gain[idx] : std::complex<double>(1, 0);
    const double foff = cal_freq ? config.calibration.frequency_offset_hz[idx] : 0.0;
    g2 += std::norm(gain);
    g4 += std::norm(gain) * std::norm(gain);
    for (int n = 0; n < Ns; ++n) {
      const std::complex<double> w = wr[n] / wr_sum * gain * std::polar(1.0, -2 * pi * foff * n / fs);
      range_w[static_cast<std::size_t>(v) * Ns + n] =
          cf(static_cast<float>(w.real()), static_cast<float>(w.imag()));
    }
  }
  shape = g4 > 0 ? g2 * g2 / g4 : V;

  const std::vector<double> wd = make_window(opt.doppler_window, L);
  double wd_sum = 0;
  for (double w : wd) wd_sum += w;
  for (int l = 0; l < L; ++l)
    doppler_w.push_back(static_cast<float>(wd[l] / wd_sum * ((l % 2) ? -1.0 : 1.0)));

  tdm.resize(static_cast<std::size_t>(S) * Nd);
  for (int k = 0; k < S; ++k)
    for (int d = 0; d < Nd; ++d) {
      const double ph =
          opt.tdm_compensation ? -2 * pi * k * (d - Nd / 2) / (static_cast<double>(S) * Nd) : 0.0;
      tdm[static_cast<std::size_t>(k) * Nd + d] =
          cf(static_cast<float>(std::cos(ph)), static_cast<float>(std::sin(ph)));
    }

  const int span = max_az - min_az + 1;
  const std::vector<double> wa = make_window(opt.angle_window, span);
  double wa_sum = 0;
  for (int p : el_pos) wa_sum += wa[p];
  sub_bin = opt.interpolation != "none";
  if (opt.interpolation == "calibrated") {
    // The calibration, channel frequency offsets and fftshift signs move a tone, not its shape.
    range_peak = PeakInterpolator(wr, Nr);
    doppler_peak = PeakInterpolator(wd, Nd);
    std::vector<double> aperture;
    for (int p : el_pos) aperture.push_back(wa[p]);
    azimuth_peak = PeakInterpolator(aperture, el_pos, Na);
  }
  angle_g.resize(el_pos.size() * Nd);
  for (std::size_t i = 0; i < el_pos.size(); ++i) {
    const int p = el_pos[i];
    const double w = wa[p] / wa_sum;
    angle_w2 += w * w;
    const int k = der.virtual_channels[el_chan[i]].slot;
    for (int d = 0; d < Nd; ++d)
      angle_g[i * Nd + d] =
          tdm[static_cast<std::size_t>(k) * Nd + d] * static_cast<float>(w * ((p % 2) ? -1.0 : 1.0));
  }

  // ---- buffers and plans (planned before any data: FFTW_MEASURE overwrites its arrays)
  const std::size_t blk = static_cast<std::size_t>(Nr) * Nd;
  rin = AlignedBuffer<cf>(static_cast<std::size_t>(Nd) * Nr);
  rout = AlignedBuffer<cf>(static_cast<std::size_t>(Nd) * Nr);
  mean_in = AlignedBuffer<cf>(static_cast<std::size_t>(Nr));
  mean_out = AlignedBuffer<cf>(static_cast<std::size_t>(Nr));
  chan = AlignedBuffer<cf>(blk * V);
  abuf = AlignedBuffer<cf>(static_cast<std::size_t>(Nd) * Na);
  obuf = AlignedBuffer<cf>(static_cast<std::size_t>(Nd) * Na);
  range_plan = FftPlan(Nr, L, 1, Nr, rin.data(), rout.data(), flags);
  mean_plan = FftPlan(Nr, 1, 1, Nr, mean_in.data(), mean_out.data(), flags);
  doppler_plan = FftPlan(Nd, Nr, rout.data(), Nr, 1, chan.data(), 1, Nd, flags);
  angle_plan = FftPlan(Na, Nd, 1, Na, abuf.data(), obuf.data(), flags);
  // Planning may have scribbled on the arrays: the zero padding must be zero.
  std::fill(rin.data(), rin.data() + rin.size(), cf{});
  std::fill(rout.data(), rout.data() + rout.size(), cf{});
  std::fill(mean_in.data(), mean_in.data() + mean_in.size(), cf{});
  std::fill(abuf.data(), abuf.data() + abuf.size(), cf{});
  // The Doppler plan runs on every channel's block: each must have the planned SIMD alignment.
  const int align0 = fftwf_alignment_of(reinterpret_cast<float*>(chan.data()));
  for (int v = 0; v < V; ++v)
    if (fftwf_alignment_of(reinterpret_cast<float*>(chan.data() + v * blk)) != align0)
      throw std::logic_error("DSP: channel block misaligned for the Doppler plan");
  for (int d = 0; d < Nd; ++d) {
    std::complex<double> acc{};
    for (int l = 0; l < L; ++l) acc += double(doppler_w[l]) * std::polar(1.0, -2 * pi * d * l / Nd);
    doppler_window_dft.emplace_back(static_cast<float>(acc.real()), static_cast<float>(acc.imag()));
  }
  rad.assign(blk * Na, 0.f);
  ra.assign(static_cast<std::size_t>(Nr) * Na, 0.f);
  rd.assign(blk, 0.f);

  setup_cfar();
  setup_elevation();

  dets.reserve(blk);
  points.reserve(static_cast<std::size_t>(opt.cfar.max_detections) * opt.max_angle_peaks);
  result.rad = rad;
  result.ra = ra;
  result.rd = rd;
  result.channels = std::span<const cf>(chan.data(), chan.size());
}

void DspProcessor::Impl::setup_cfar() {
  const CfarOptions& c = opt.cfar;
  auto fail = [](const std::string& key, const std::string& what) {
    throw ConfigError("<dsp options>", "dsp.cfar." + key, what);
  };
  const int wo = c.guard_doppler + c.train_doppler;
  if (2 * wo + 1 > Nd)
    fail("train_doppler", "guard_doppler + train_doppler <= " + std::to_string((Nd - 1) / 2) +
                              " (the Doppler axis has " + std::to_string(Nd) + " bins)");
  r_lo = std::min(c.discard_near_bins, Nr);
  // -1: the top tenth of the range bins, where TI's IF filter (and rsrio-sim's) tapers the band:
  // the noise floor falls there and a CA window straddling the edge raises false alarms.
  const int far = c.discard_far_bins >= 0 ? c.discard_far_bins : (Nr + 9) / 10;
  r_hi = std::max(r_lo, Nr - far);
  const bool os = c.type == "os";
  // Correlation of neighbouring FFT cells from the (zero-padded) windows: |rho(k)|^2 for a lag of
  // k bins, rho(k) = sum_n w[n]^2 exp(-j 2 pi k n / N) / sum_n w[n]^2.
  auto rho2 = [](const std::vector<double>& w, int n_fft) {
    std::vector<double> out(static_cast<std::size_t>(n_fft));
    double s2 = 0;
    for (double x : w) s2 += x * x;
    for (int k = 0; k < n_fft; ++k) {
      std::complex<double> acc{};
      for (std::size_t n = 0; n < w.size(); ++n)
        acc += w[n] * w[n] * std::polar(1.0, -2 * std::numbers::pi * k * static_cast<double>(n) / n_fft);
      out[static_cast<std::size_t>(k)] = std::norm(acc) / (s2 * s2);
    }
    return out;
  };
  const std::vector<double> rr2 = rho2(make_window(opt.range_window, Ns), Nr);
  const std::vector<double> rd2 = rho2(make_window(opt.doppler_window, L), Nd);
  // Effective number of training cells at offsets (dr, dd) from the cell under test.
  auto effective = [&](const std::vector<std::pair<int, int>>& cells) {
    double sum = 0;
    for (const auto& [ra_, da] : cells)
      for (const auto& [rb, db] : cells)
        sum += rr2[static_cast<std::size_t>(((ra_ - rb) % Nr + Nr) % Nr)] *
               rd2[static_cast<std::size_t>(((da - db) % Nd + Nd) % Nd)];
    const double n = static_cast<double>(cells.size());
    return sum > 0 ? std::min(n, n * n / sum) : n;
  };
  std::map<std::vector<std::pair<int, int>>, CfarDesign> cache;
  auto design = [&](const std::vector<std::pair<int, int>>& cells) {
    auto it = cache.find(cells);
    if (it != cache.end()) return it->second;
    CfarDesign dz;
    dz.count = static_cast<int>(cells.size());
    if (dz.count >= 1) {
      if (os) {
        dz.k = cfar::os_k(c.os_rank, dz.count);
        dz.alpha = cfar::os_alpha(c.pfa, dz.count, dz.k, shape);
        dz.mean_ratio = cfar::os_mean_ratio(dz.count, dz.k, shape);
      } else {
        dz.n_eff = std::max(1.0, effective(cells));
        dz.alpha = cfar::ca_alpha(c.pfa, dz.n_eff, shape);
      }
    }
    cache.emplace(cells, dz);
    return dz;
  };
  row_design.assign(Nr, CfarDesign{});
  int max_count = 0;
  std::vector<std::pair<int, int>> cells;
  for (int r = r_lo; r < r_hi; ++r) {
    cells.clear();
    const int lo = std::max(r_lo, r - c.guard_range - c.train_range) - r;
    const int hi = std::min(r_hi - 1, r + c.guard_range + c.train_range) - r;
    for (int dr = lo; dr <= hi; ++dr) {
      const bool guard_row = std::abs(dr) <= c.guard_range;
      if (c.mode == "2d") {
        for (int dd = -wo; dd <= wo; ++dd)
          if (!(guard_row && std::abs(dd) <= c.guard_doppler)) cells.emplace_back(dr, dd);
      } else if (!guard_row) {
        cells.emplace_back(dr, 0);
      }
    }
    row_design[r] = design(cells);
    max_count = std::max(max_count, row_design[r].count);
  }
  if (c.mode == "dual_pass") {
    cells.clear();
    for (int j = c.guard_doppler + 1; j <= wo; ++j) {
      cells.emplace_back(0, -j);
      cells.emplace_back(0, j);
    }
    doppler_design = design(cells);
    max_count = std::max(max_count, doppler_design.count);
  }
  os_scratch.assign(static_cast<std::size_t>(std::max(1, max_count)), 0.f);
  pad = wo + 1;  // the running Doppler sums read one cell beyond the window
  rdx.assign(static_cast<std::size_t>(Nr) * (Nd + 2 * pad), 0.f);
  cum_outer.assign(static_cast<std::size_t>(Nr + 1) * Nd, 0.0);
  cum_guard.assign(static_cast<std::size_t>(Nr + 1) * Nd, 0.0);
}

void DspProcessor::Impl::setup_elevation() {
  int min_el = std::numeric_limits<int>::max();
  for (const auto& vc : der.virtual_channels) min_el = std::min(min_el, vc.elevation);
  std::map<int, int> ref_at;  // azimuth position -> filled-array channel
  for (std::size_t i = 0; i < el_chan.size(); ++i)
    ref_at[der.virtual_channels[el_chan[i]].azimuth] = el_chan[i];
  std::map<int, ElevationRow> by_dq;
  for (int v = 0; v < V; ++v) {
    const auto& vc = der.virtual_channels[v];
    if (vc.elevation == min_el) continue;
    auto it = ref_at.find(vc.azimuth);
    if (it == ref_at.end()) continue;
    ElevationRow& row = by_dq[vc.elevation - min_el];
    row.dq = vc.elevation - min_el;
    row.elevated.push_back(v);
    row.reference.push_back(it->second);
    row.position.push_back(vc.azimuth);
  }
  for (auto& [dq, row] : by_dq) rows.push_back(std::move(row));
  grids.has_elevation = !rows.empty();
  const int ng = static_cast<int>(std::lround(2.0 / kElevationStep)) + 1;
  for (int g = 0; g < ng; ++g) uz_grid.push_back(-1.0 + g * kElevationStep);
  const double dsp_d = der.element_spacing_wavelengths;
  for (const auto& row : rows)
    for (double uz : uz_grid)
      elev_table.push_back(std::polar(1.0, 2 * std::numbers::pi * dsp_d * row.dq * uz));
  row_z.assign(rows.size(), {});
}

void DspProcessor::Impl::run_ffts(const AdcCube& cube) {
  const std::size_t blk = static_cast<std::size_t>(Nr) * Nd;
  const cf* in = cube.data.data();
  for (int v = 0; v < V; ++v) {
    const int k = v / R, rx = v % R;
    const cf* w = range_w.data() + static_cast<std::size_t>(v) * Ns;
    // 1. DC removal, window, calibration; range FFT of all loops of this channel.
    for (int l = 0; l < L; ++l) {
      const cf* x = in + ((static_cast<std::size_t>(l) * S + k) * R + rx) * Ns;
      if (l + 1 < L) {
        // The next chirp of this channel is a whole loop further on (S R N_s samples): fetch it
        // while this one is processed.
        const char* next = reinterpret_cast<const char*>(x + static_cast<std::size_t>(S) * R * Ns);
        for (std::size_t b = 0; b < static_cast<std::size_t>(Ns) * sizeof(cf); b += 64)
          __builtin_prefetch(next + b);
      }
      cf* dst = rin.data() + static_cast<std::size_t>(l) * Nr;
      cf mean{};
      if (opt.dc_removal) {
        // Eight partial sums (four real, four imaginary): vectorisable, unlike one running sum.
        const float* xf = reinterpret_cast<const float*>(x);
        float acc[8] = {};
        int i = 0;
        for (; i + 8 <= 2 * Ns; i += 8)
          for (int j = 0; j < 8; ++j) acc[j] += xf[i + j];
        for (; i < 2 * Ns; ++i) acc[i % 8] += xf[i];
        const float sr = (acc[0] + acc[2]) + (acc[4] + acc[6]), si = (acc[1] + acc[3]) + (acc[5] + acc[7]);
        mean = cf(sr / Ns, si / Ns);
      }
      // The Doppler window (with the fftshift sign) is a per-chirp factor: applied here, the range
      // FFT (linear) carries it to where the Doppler FFT needs it.
      const float wl = doppler_w[l];
      if (opt.clutter_removal) {
        for (int n = 0; n < Ns; ++n) {
          const cf y = cmul(x[n] - mean, w[n]);
          mean_in[n] += y;
          dst[n] = y * wl;
        }
      } else {
        for (int n = 0; n < Ns; ++n) dst[n] = cmul(x[n] - mean, w[n]) * wl;
      }
    }
    range_plan.execute();
    // 3. Doppler FFT straight down the columns of the [loop][range] block (rows L..N_d-1 stay
    //    zero: the zero padding), written as [range][doppler].
    cf* out = chan.data() + v * blk;
    doppler_plan.execute(rout.data(), out);
    // 2. clutter removal: subtracting the mean over loops m[r] from every loop before the
    //    windowed Doppler FFT is subtracting m[r] WD[d] after it (WD = DFT of the Doppler
    //    window), and m is the range FFT of the mean chirp (linearity).
    if (opt.clutter_removal) {
      const float inv = 1.0f / static_cast<float>(L);
      for (int n = 0; n < Ns; ++n) mean_in[n] *= inv;
      mean_plan.execute();
      std::fill(mean_in.data(), mean_in.data() + Ns, cf{});
      for (int r = 0; r < Nr; ++r) {
        const cf m = mean_out[r];
        cf* row = out + static_cast<std::size_t>(r) * Nd;
        for (int d = 0; d < Nd; ++d) row[d] -= cmul(m, doppler_window_dft[d]);
      }
    }
    float* rdp = rd.data();
    if (v == 0)
      for (std::size_t i = 0; i < blk; ++i) rdp[i] = power(out[i]);
    else
      for (std::size_t i = 0; i < blk; ++i) rdp[i] += power(out[i]);
  }
  // 4.-5. TDM compensation, angle FFT per range bin; RAD and RA.
  const std::size_t ne = el_pos.size();
  for (int r = 0; r < Nr; ++r) {
    for (std::size_t i = 0; i < ne; ++i) {
      const cf* src = chan.data() + (static_cast<std::size_t>(el_chan[i]) * Nr + r) * Nd;
      if (i + 1 < ne) {
        const char* next = reinterpret_cast<const char*>(
            chan.data() + (static_cast<std::size_t>(el_chan[i + 1]) * Nr + r) * Nd);
        for (std::size_t b = 0; b < static_cast<std::size_t>(Nd) * sizeof(cf); b += 64)
          __builtin_prefetch(next + b);
      }
      const cf* g = angle_g.data() + i * Nd;
      cf* dst = abuf.data() + el_pos[i];
      for (int d = 0; d < Nd; ++d) dst[static_cast<std::size_t>(d) * Na] = cmul(src[d], g[d]);
    }
    angle_plan.execute();
    float* radr = rad.data() + static_cast<std::size_t>(r) * Na * Nd;
    float* rar = ra.data() + static_cast<std::size_t>(r) * Na;
    std::fill(rar, rar + Na, 0.f);
    for (int d = 0; d < Nd; ++d) {
      const cf* o = obuf.data() + static_cast<std::size_t>(d) * Na;
      for (int a = 0; a < Na; ++a) {
        const float p = power(o[a]);
        radr[static_cast<std::size_t>(d) * Na + a] = p;
        rar[a] += p;
      }
    }
  }
}

void DspProcessor::Impl::run_cfar() {
  const CfarOptions& c = opt.cfar;
  dets.clear();
  result.cells_tested = static_cast<std::size_t>(r_hi - r_lo) * Nd;
  if (r_hi <= r_lo) return;
  const bool os = c.type == "os";
  const int gd = c.guard_doppler, wo = c.guard_doppler + c.train_doppler;
  const int W = Nd + 2 * pad;
  // RD rows of the CFAR region with circular Doppler padding: window accesses need no modulo.
  for (int r = r_lo; r < r_hi; ++r) {
    const float* src = rd.data() + static_cast<std::size_t>(r) * Nd;
    float* dst = rdx.data() + static_cast<std::size_t>(r) * W;
    for (int j = 0; j < W; ++j) dst[j] = src[((j - pad) % Nd + Nd) % Nd];
  }
  // x(r, d + j) for |j| <= pad
  auto row = [&](int r) { return rdx.data() + static_cast<std::size_t>(r) * W + pad; };
  auto at = [&](int r, int d) { return rd[static_cast<std::size_t>(r) * Nd + d]; };
  auto wrap = [&](int d) { return ((d % Nd) + Nd) % Nd; };
  auto local_max = [&](int r, int d, float p) {
    for (int dr = -1; dr <= 1; ++dr) {
      const int rr = r + dr;
      if (rr < 0 || rr >= Nr) continue;
      for (int dd = -1; dd <= 1; ++dd) {
        if (dr == 0 && dd == 0) continue;
        const float q = at(rr, wrap(d + dd));
        const bool before = dr < 0 || (dr == 0 && dd < 0);
        if (before ? q >= p : q > p) return false;
      }
    }
    return true;
  };
  auto os_value = [&](int n, int k) {
    std::nth_element(os_scratch.begin(), os_scratch.begin() + (k - 1), os_scratch.begin() + n);
    return os_scratch[k - 1];
  };
  auto push = [&](int r, int d, float p, double noise, double thr) {
    if (c.peak_grouping && !local_max(r, d, p)) return;
    DspDetection det;
    det.range_bin = r;
    det.doppler_bin = d;
    det.power = p;
    det.noise = static_cast<float>(noise);
    det.threshold = static_cast<float>(thr);
    det.snr_db = static_cast<float>(10.0 * std::log10(std::max(1e-30, p / std::max(noise, 1e-30))));
    dets.push_back(det);
  };

  if (c.mode == "2d") {
    if (!os) {
      // Doppler window sums per row (prefix sums along the padded row), then prefix sums over
      // range: every 2-D window sum is four lookups. Doubles keep the differences exact enough.
      std::fill(cum_outer.begin() + static_cast<long>(r_lo) * Nd,
                cum_outer.begin() + static_cast<long>(r_lo + 1) * Nd, 0.0);
      std::fill(cum_guard.begin() + static_cast<long>(r_lo) * Nd,
                cum_guard.begin() + static_cast<long>(r_lo + 1) * Nd, 0.0);
      for (int r = r_lo; r < r_hi; ++r) {
        const float* x = row(r);
        const double* po = cum_outer.data() + static_cast<std::size_t>(r) * Nd;
        const double* pg = cum_guard.data() + static_cast<std::size_t>(r) * Nd;
        double* no = cum_outer.data() + static_cast<std::size_t>(r + 1) * Nd;
        double* ng = cum_guard.data() + static_cast<std::size_t>(r + 1) * Nd;
        double so = 0, sg = 0;
        for (int j = -wo; j <= wo; ++j) so += x[j];
        for (int j = -gd; j <= gd; ++j) sg += x[j];
        for (int d = 0; d < Nd; ++d) {
          no[d] = po[d] + so;
          ng[d] = pg[d] + sg;
          so += static_cast<double>(x[d + wo + 1]) - x[d - wo];
          sg += static_cast<double>(x[d + gd + 1]) - x[d - gd];
        }
      }
    }
    for (int r = r_lo; r < r_hi; ++r) {
      const CfarDesign& dz = row_design[r];
      if (dz.count < 1) continue;
      const int ro_lo = std::max(r_lo, r - c.guard_range - c.train_range);
      const int ro_hi = std::min(r_hi - 1, r + c.guard_range + c.train_range);
      const int rg_lo = std::max(r_lo, r - c.guard_range), rg_hi = std::min(r_hi - 1, r + c.guard_range);
      const float* cut_row = row(r);
      if (!os) {
        const double* o1 = cum_outer.data() + static_cast<std::size_t>(ro_hi + 1) * Nd;
        const double* o0 = cum_outer.data() + static_cast<std::size_t>(ro_lo) * Nd;
        const double* g1 = cum_guard.data() + static_cast<std::size_t>(rg_hi + 1) * Nd;
        const double* g0 = cum_guard.data() + static_cast<std::size_t>(rg_lo) * Nd;
        const double inv = 1.0 / dz.count;
        for (int d = 0; d < Nd; ++d) {
          const double noise = std::max(0.0, (o1[d] - o0[d]) - (g1[d] - g0[d])) * inv;
          const double thr = dz.alpha * noise;
          if (cut_row[d] > thr) push(r, d, cut_row[d], noise, thr);
        }
      } else {
        for (int d = 0; d < Nd; ++d) {
          int n = 0;
          for (int rr = ro_lo; rr <= ro_hi; ++rr) {
            const float* x = row(rr) + d;
            if (rr >= rg_lo && rr <= rg_hi) {
              for (int j = -wo; j < -gd; ++j) os_scratch[n++] = x[j];
              for (int j = gd + 1; j <= wo; ++j) os_scratch[n++] = x[j];
            } else {
              for (int j = -wo; j <= wo; ++j) os_scratch[n++] = x[j];
            }
          }
          const double xk = os_value(n, dz.k);
          const double thr = dz.alpha * xk;
          if (cut_row[d] > thr) push(r, d, cut_row[d], xk / dz.mean_ratio, thr);
        }
      }
    }
  } else {  // dual pass: range pass AND Doppler pass
    const int g = c.guard_range, t = c.train_range;
    const CfarDesign& dd = doppler_design;
    for (int r = r_lo; r < r_hi; ++r) {
      const CfarDesign& dz = row_design[r];
      if (dz.count < 1) continue;
      const float* cut_row = row(r);
      for (int d = 0; d < Nd; ++d) {
        const float cut = cut_row[d];
        // range pass
        int n = 0;
        double s = 0;
        for (int rr = std::max(r_lo, r - g - t); rr <= std::min(r_hi - 1, r + g + t); ++rr) {
          if (rr >= r - g && rr <= r + g) continue;
          const float q = rd[static_cast<std::size_t>(rr) * Nd + d];
          s += q;
          if (os) os_scratch[n] = q;
          ++n;
        }
        double noise, thr;
        if (!os) {
          noise = s / n;
          thr = dz.alpha * noise;
        } else {
          const double xk = os_value(n, dz.k);
          thr = dz.alpha * xk;
          noise = xk / dz.mean_ratio;
        }
        if (!(cut > thr)) continue;
        // Doppler pass (circular)
        double s2 = 0;
        int m = 0;
        for (int j = gd + 1; j <= wo; ++j) {
          const float a = cut_row[d - j], b = cut_row[d + j];
          s2 += static_cast<double>(a) + b;
          if (os) {
            os_scratch[m++] = a;
            os_scratch[m++] = b;
          }
        }
        const double thr2 = os ? dd.alpha * os_value(m, dd.k) : dd.alpha * s2 / (2 * c.train_doppler);
        if (cut > thr2) push(r, d, cut, noise, thr);
      }
    }
  }
  if (dets.size() > static_cast<std::size_t>(c.max_detections)) {
    std::nth_element(dets.begin(), dets.begin() + c.max_detections, dets.end(),
                     [](const DspDetection& a, const DspDetection& b) { return a.power > b.power; });
    dets.resize(static_cast<std::size_t>(c.max_detections));
  }
  std::sort(dets.begin(), dets.end(), [](const DspDetection& a, const DspDetection& b) {
    return a.range_bin != b.range_bin ? a.range_bin < b.range_bin : a.doppler_bin < b.doppler_bin;
  });
}

float DspProcessor::Impl::elevation_uz(int r, int d, double uy, bool& measured) {
  measured = false;
  if (rows.empty()) return 0.f;
  const double two_pi_d = 2 * std::numbers::pi * der.element_spacing_wavelengths;
  auto value = [&](int v) {
    const cf x = cmul(chan[(static_cast<std::size_t>(v) * Nr + r) * Nd + d],
                      tdm[static_cast<std::size_t>(der.virtual_channels[v].slot) * Nd + d]);
    return std::complex<double>(x.real(), x.imag());
  };
  auto& z = row_z;
  for (std::size_t q = 0; q < rows.size(); ++q) {
    std::complex<double> ye{}, y0{};
    const ElevationRow& row = rows[q];
    for (std::size_t e = 0; e < row.elevated.size(); ++e) {
      const std::complex<double> steer =
          std::polar(1.0, two_pi_d * row.position[e] * uy);  // undo -2 pi d p u_y
      ye += value(row.elevated[e]) * steer;
      y0 += value(row.reference[e]) * steer;
    }
    z[q] = ye * std::conj(y0);
  }
  const double uz_max = std::sqrt(std::max(0.0, 1.0 - uy * uy));
  const int ng = static_cast<int>(uz_grid.size());
  // Each row's cross product is rotated back by its elevation phase: the right u_z puts all of
  // them on the positive real axis (the real part, not the magnitude: one row alone has a
  // magnitude that does not depend on u_z).
  auto score = [&](int g) {
    std::complex<double> s{};
    for (std::size_t q = 0; q < rows.size(); ++q) s += z[q] * elev_table[q * ng + g];
    return s.real();
  };
  int best = -1;
  double best_s = -std::numeric_limits<double>::max();
  for (int g = 0; g < ng; ++g) {
    if (std::fabs(uz_grid[g]) > uz_max + 1e-12) continue;
    const double s = score(g);
    if (s > best_s) {
      best_s = s;
      best = g;
    }
  }
  if (best < 0 || !(best_s > 0)) return 0.f;  // no coherent elevation signal
  double uz = uz_grid[best];
  if (best > 0 && best + 1 < ng) {
    const double l = score(best - 1), c = best_s, rr = score(best + 1);
    const double den = l - 2 * c + rr;
    if (den < 0) uz += std::clamp(0.5 * (l - rr) / den, -0.5, 0.5) * kElevationStep;
  }
  measured = true;
  return static_cast<float>(std::clamp(uz, -uz_max, uz_max));
}

void DspProcessor::Impl::make_points() {
  points.clear();
  const double rad2deg = 180.0 / std::numbers::pi;
  const float rel = static_cast<float>(std::pow(10.0, -opt.angle_peak_db / 10.0));
  const int kmax = std::min(opt.max_angle_peaks, kMaxAnglePeaks);
  for (std::size_t j = 0; j < dets.size(); ++j) {
    const DspDetection& det = dets[j];
    const int r = det.range_bin, d = det.doppler_bin;
    std::array<int, kMaxAnglePeaks> pk{};
    std::array<float, kMaxAnglePeaks> pv{};
    int npk = 0;
    for (int a = 0; a < Na; ++a) {
      if (!az_valid[a]) continue;
      const float p = rad_at(r, a, d);
      if (Na > 1) {
        const float left = rad_at(r, (a - 1 + Na) % Na, d), right = rad_at(r, (a + 1) % Na, d);
        if (!(p > left && p >= right)) continue;
      }
      if (npk == kmax && p <= pv[npk - 1]) continue;
      int pos = npk == kmax ? kmax - 1 : npk++;
      while (pos > 0 && pv[pos - 1] < p) {
        pv[pos] = pv[pos - 1];
        pk[pos] = pk[pos - 1];
        --pos;
      }
      pv[pos] = p;
      pk[pos] = a;
    }
    for (int i = 0; i < npk; ++i) {
      if (pv[i] < pv[0] * rel || !(pv[i] > 0)) break;
      const int a = pk[i];
      // The point's own Doppler bin: its azimuth peak was found in the detection's Doppler bin d,
      // but a return at another azimuth of the same range ring reaches bin d from anywhere in the
      // Doppler window's main lobe (a static scene seen while moving: the Doppler changes with
      // the angle), and a fit over d - 1, d, d + 1 that is not peaked at d would put it at d.
      // Climb RAD along Doppler at this azimuth to its maximum, at most the main lobe away.
      int dp = d;
      if (opt.doppler_own_peak && Nd > 2)
        for (int step = 0; step < doppler_climb; ++step) {
          const float here = rad_at(r, a, dp), up = rad_at(r, a, (dp + 1) % Nd),
                      down = rad_at(r, a, (dp - 1 + Nd) % Nd);
          if (up > here && up >= down)
            dp = (dp + 1) % Nd;
          else if (down > here)
            dp = (dp - 1 + Nd) % Nd;
          else
            break;
        }
      const float peak = rad_at(r, a, dp);
      float da = 0, dr = 0, ddp = 0;
      if (sub_bin) {
        if (Na > 2) da = azimuth_peak.offset(rad_at(r, (a - 1 + Na) % Na, d), pv[i], rad_at(r, (a + 1) % Na, d));
        if (r > 0 && r + 1 < Nr) dr = range_peak.offset(rad_at(r - 1, a, dp), peak, rad_at(r + 1, a, dp));
        if (Nd > 2) ddp = doppler_peak.offset(rad_at(r, a, (dp - 1 + Nd) % Nd), peak, rad_at(r, a, (dp + 1) % Nd));
      }
      DspPoint pt;
      pt.detection = static_cast<int>(j);
      pt.power = peak;
      pt.range_bin = static_cast<float>(r) + dr;
      pt.doppler_bin = static_cast<float>(dp) + ddp;
      pt.azimuth_bin = static_cast<float>(a) + da;
      pt.range_m = static_cast<float>(pt.range_bin * der.range_bin_size_m);
      pt.doppler_mps = static_cast<float>((pt.doppler_bin - Nd / 2) * der.velocity_bin_size_mps);
      const double uy_grid = (pt.azimuth_bin - Na / 2) * grids.azimuth_sin_bin;
      pt.azimuth_ambiguous = std::fabs(uy_grid) > grids.azimuth_unambiguous_sin;
      const double uy = std::clamp(uy_grid, -1.0, 1.0);
      bool measured = false;
      double uz = elevation_uz(r, dp, uy, measured);
      pt.elevation_measured = measured;
      const double ux = std::sqrt(std::max(0.0, 1.0 - uy * uy - uz * uz));
      pt.azimuth_deg = static_cast<float>(std::atan2(uy, ux) * rad2deg);
      pt.elevation_deg = static_cast<float>(std::asin(std::clamp(uz, -1.0, 1.0)) * rad2deg);
      pt.x = static_cast<float>(pt.range_m * ux);
      pt.y = static_cast<float>(pt.range_m * uy);
      pt.z = static_cast<float>(pt.range_m * uz);
      const double noise_rad = static_cast<double>(det.noise) / V * angle_w2;
      pt.snr_db = static_cast<float>(10.0 * std::log10(std::max(1e-30, peak / std::max(noise_rad, 1e-30))));
      points.push_back(pt);
    }
  }
}

DspProcessor::DspProcessor(const RadarConfig& config, const DspOptions& options)
    : impl_(std::make_unique<Impl>(config, options)) {}
DspProcessor::~DspProcessor() = default;
DspProcessor::DspProcessor(DspProcessor&&) noexcept = default;
DspProcessor& DspProcessor::operator=(DspProcessor&&) noexcept = default;

const DspResult& DspProcessor::process(const AdcCube& cube) {
  Impl& m = *impl_;
  if (cube.loops != m.L || cube.slots != m.S || cube.rx != m.R || cube.samples != m.Ns ||
      cube.data.size() != static_cast<std::size_t>(m.L) * m.S * m.R * m.Ns)
    throw std::invalid_argument("DSP: the ADC cube's shape (" + std::to_string(cube.loops) + " loops, " +
                                std::to_string(cube.slots) + " slots, " + std::to_string(cube.rx) + " RX, " +
                                std::to_string(cube.samples) + " samples) is not the configuration's (" +
                                std::to_string(m.L) + ", " + std::to_string(m.S) + ", " +
                                std::to_string(m.R) + ", " + std::to_string(m.Ns) + ")");
  m.run_ffts(cube);
  m.run_cfar();
  m.make_points();
  m.result.detections = m.dets;
  m.result.points = m.points;
  ++m.result.frames;
  return m.result;
}

const DspResult& DspProcessor::result() const {
  return impl_->result;
}
const DspGrids& DspProcessor::grids() const {
  return impl_->grids;
}
const RadarConfig& DspProcessor::config() const {
  return impl_->config;
}
const DspOptions& DspProcessor::options() const {
  return impl_->opt;
}
double DspProcessor::cfar_alpha(int r) const {
  return r >= 0 && r < impl_->Nr ? impl_->row_design[r].alpha : 0.0;
}
int DspProcessor::cfar_training_cells(int r) const {
  return r >= 0 && r < impl_->Nr ? impl_->row_design[r].count : 0;
}
double DspProcessor::cfar_shape() const {
  return impl_->shape;
}

}  // namespace rsrio
