#include "rsrio/sim/radar_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "kernels.hpp"
#include "nufft.hpp"
#include "random.hpp"
#include "worker_pool.hpp"

namespace rsrio::sim {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kC = kSpeedOfLight;
constexpr double kBoltzmann = 1.380649e-23;
constexpr double kT0 = 290.0;
constexpr int kTaps = detail::SpreadKernel::kWidth;
constexpr std::size_t kNoiseBlock = 256;

enum Stream : std::uint64_t { kNoiseStream = 101, kLeakageStream, kChannelStream };

double db_to_power(double db) { return std::pow(10.0, db / 10.0); }

}  // namespace

struct RadarSimulator::Impl {
  // Per-chirp geometry of every visible scatterer (structure of arrays: the loops vectorise).
  struct ChirpGeometry {
    std::vector<double> psi, x, uy, uz;  // phase at sample N/2 [cycles], beat [cycles/sample], direction
    std::vector<float> amp_re, amp_im;   // amplitude incl. 1/R^2 [LSB]
    void reserve(std::size_t n) {
      for (auto* v : {&psi, &x, &uy, &uz}) v->resize(n);
      for (auto* v : {&amp_re, &amp_im}) v->resize(n);
    }
  };
  struct Scratch {
    ChirpGeometry geo;
    std::vector<float> grid_re, grid_im;  // [rx][G + kTaps]: the padded NUFFT grid
    std::vector<float> c_re, c_im;
    std::vector<std::uint64_t> random;    // noise: one block of raw random bits
    std::size_t saturated = 0;
    double max_abs = 0;
  };

  RadarConfig config;
  RadarDerived derived;
  RadarModelOptions options;
  const Scene& scene;
  const Motion& body;
  Mount mount;
  std::uint64_t seed;

  int loops = 0, n_tx = 0, n_rx = 0, n_samples = 0, half = 0, grid_size = 0, grid_stride = 0;
  double slope = 0, fs = 0, fc = 0, tc = 0, idle = 0, t_adc = 0, period = 0, active = 0, max_range = 0;
  double amp_k = 0;
  std::vector<double> tx_az, tx_el, rx_az, rx_el;  // positions x element spacing, in wavelengths
  std::vector<float> chan_re, chan_im;             // [slot * n_rx + rx] channel gain errors
  std::vector<float> leak_re, leak_im;             // [slot * n_rx + rx]
  double leak_x = 0;
  std::vector<float> deconv;                       // [sample]
  detail::SpreadKernel kernel;
  detail::InverseFft fft;

  // The frame being made.
  double t_mid = 0;
  std::size_t n_visible = 0;
  std::vector<double> px, py, pz, vx, vy, vz, ax, ay, az;  // world, at t_mid
  std::vector<float> base_re, base_im;                     // amplitude without 1/R^2
  std::vector<Scatterer> dynamic;
  std::vector<int> near_occluders, near_cylinders;
  std::vector<Scratch> scratch;
  detail::WorkerPool pool;

  Impl(const RadarConfig& c, const RadarModelOptions& o, const Scene& s, const Motion& b, const Mount& m,
       std::uint64_t sd, int threads)
      : config(c), derived(derive(c)), options(o), scene(s), body(b), mount(m), seed(sd),
        fft(2 * next_power_of_two(c.chirp.samples_per_chirp)), pool(threads) {
    if (!(o.noise_rms_lsb > 0)) throw std::invalid_argument("noise_rms_lsb must be positive (it sets the ADC scale)");
    if (derived.num_rx > 64) throw std::invalid_argument("the simulator handles at most 64 RX channels");
    loops = c.loops;
    n_tx = derived.num_tx;
    n_rx = derived.num_rx;
    n_samples = c.chirp.samples_per_chirp;
    half = n_samples / 2;
    grid_size = fft.size();
    grid_stride = grid_size + kTaps;
    slope = c.chirp.slope_mhz_per_us * 1e12;
    fs = c.chirp.adc_sample_rate_ksps * 1e3;
    fc = derived.center_frequency_hz;
    tc = derived.chirp_interval_s;
    idle = c.chirp.idle_time_us * 1e-6;
    t_adc = c.chirp.adc_start_time_us * 1e-6;
    period = c.frame_period_ms * 1e-3;
    active = derived.frame_active_time_s;
    max_range = derived.max_range_m;

    const double lambda = derived.wavelength_m;
    const double snr_1m2_1m = db_to_power(o.tx_power_dbm - 30) * db_to_power(o.tx_gain_dbi) *
                              db_to_power(o.rx_gain_dbi) * lambda * lambda /
                              (std::pow(4 * kPi, 3) * db_to_power(o.system_loss_db) * kBoltzmann * kT0 *
                               db_to_power(o.noise_figure_db) * fs);
    amp_k = o.noise_rms_lsb * std::sqrt(snr_1m2_1m);

    const double d = derived.element_spacing_wavelengths;
    for (int k = 0; k < n_tx; ++k) {
      const int tx = c.tx_order[k];
      tx_az.push_back(d * c.array.tx_azimuth[tx]);
      tx_el.push_back(d * c.array.tx_elevation[tx]);
    }
    for (int r = 0; r < n_rx; ++r) {
      rx_az.push_back(d * c.array.rx_azimuth[r]);
      rx_el.push_back(d * c.array.rx_elevation[r]);
    }
    // The radar frame's origin is the array's phase centre: the mean over the channels of the TX-RX
    // midpoints. The plane-wave steering phase -(tx + rx) . u is referenced to one point, and its
    // change from chirp to chirp gives every channel the Doppler of its own midpoint, so the summed
    // Doppler is that of the channels' mean midpoint. Referenced anywhere else, angle and Doppler
    // belong to different points: the cascade's antenna 0 sits 4.2 cm off its phase centre, and
    // walls 1.2 m to either side then turned the ego-velocity by +0.5 deg (Doppler error
    // -v c sin(theta) cos(theta) / r, found by rsrio-odometry-bench's corridor rows).
    const auto centre = [](std::vector<double>& v) {
      double mean = 0;
      for (double x : v) mean += x / static_cast<double>(v.size());
      for (double& x : v) x -= mean;
    };
    centre(tx_az);
    centre(tx_el);
    centre(rx_az);
    centre(rx_el);

    // Channel gain/phase errors per (TX antenna, RX), and the calibration that undoes them.
    const std::size_t n_ant = c.array.tx_azimuth.size();
    chan_re.assign(static_cast<std::size_t>(n_tx) * n_rx, 1.0f);
    chan_im.assign(static_cast<std::size_t>(n_tx) * n_rx, 0.0f);
    if (o.channel_gain_error_db > 0 || o.channel_phase_error_deg > 0) {
      detail::Random rng(detail::stream_seed(seed, kChannelStream));
      std::vector<std::complex<double>> per_antenna(n_ant * n_rx);
      for (auto& g : per_antenna)
        g = std::polar(std::pow(10.0, o.channel_gain_error_db * rng.normal() / 20),
                       o.channel_phase_error_deg * kPi / 180 * rng.normal());
      config.calibration.gain.resize(n_ant * n_rx);
      for (std::size_t i = 0; i < per_antenna.size(); ++i) config.calibration.gain[i] = 1.0 / per_antenna[i];
      for (int k = 0; k < n_tx; ++k)
        for (int r = 0; r < n_rx; ++r) {
          const auto g = per_antenna[static_cast<std::size_t>(c.tx_order[k]) * n_rx + r];
          chan_re[k * n_rx + r] = static_cast<float>(g.real());
          chan_im[k * n_rx + r] = static_cast<float>(g.imag());
        }
    }

    // TX-RX leakage: a zero-Doppler tone at a fixed short range, its phase set by each channel's
    // coupling path (random, fixed).
    leak_re.assign(static_cast<std::size_t>(n_tx) * n_rx, 0.0f);
    leak_im.assign(static_cast<std::size_t>(n_tx) * n_rx, 0.0f);
    if (o.leakage_amplitude_lsb > 0) {
      detail::Random rng(detail::stream_seed(seed, kLeakageStream));
      for (std::size_t i = 0; i < leak_re.size(); ++i) {
        const double ph = 2 * kPi * rng.uniform();
        leak_re[i] = static_cast<float>(o.leakage_amplitude_lsb * std::cos(ph));
        leak_im[i] = static_cast<float>(o.leakage_amplitude_lsb * std::sin(ph));
      }
    }
    leak_x = 2 * slope * o.leakage_range_m / kC / fs;

    // NUFFT deconvolution: 1 / phi_hat at each output sample's frequency (n - N/2) / G.
    deconv.resize(static_cast<std::size_t>(n_samples));
    for (int n = 0; n < n_samples; ++n)
      deconv[n] = static_cast<float>(1.0 / kernel.fourier(static_cast<double>(n - half) / grid_size));

    const std::size_t capacity = scene.static_scatterers().size() + scene.max_dynamic_scatterers();
    for (auto* v : {&px, &py, &pz, &vx, &vy, &vz, &ax, &ay, &az}) v->resize(capacity);
    for (auto* v : {&base_re, &base_im}) v->resize(capacity);
    dynamic.reserve(scene.max_dynamic_scatterers());
    near_occluders.reserve(scene.occluders().size());
    near_cylinders.reserve(scene.cylinders().size());
    scratch.resize(static_cast<std::size_t>(pool.size()));
    for (Scratch& w : scratch) {
      w.geo.reserve(capacity);
      w.grid_re.assign(static_cast<std::size_t>(grid_stride) * n_rx, 0.0f);
      w.grid_im.assign(static_cast<std::size_t>(grid_stride) * n_rx, 0.0f);
      w.random.resize(kNoiseBlock);
      w.c_re.resize(static_cast<std::size_t>(n_rx));
      w.c_im.resize(static_cast<std::size_t>(n_rx));
    }
  }

  double frame_start(std::uint64_t k) const { return options.first_frame_s + static_cast<double>(k) * period; }
  double chirp_time(std::uint64_t k, int loop, int slot) const {
    return frame_start(k) + (loop * n_tx + slot) * tc + idle + t_adc + half / fs;
  }

  // IF response at beat frequency f: first-order high-pass times the decimation filter's band.
  std::complex<double> if_response(double f) const {
    std::complex<double> h = 1.0;
    if (options.if_highpass_khz > 0) {
      const std::complex<double> jr(0.0, f / (options.if_highpass_khz * 1e3));
      h = jr / (1.0 + jr);
    }
    const double af = std::abs(f), edge = options.if_passband_fraction * fs;
    if (af >= fs) return 0.0;
    if (af > edge) h *= 0.5 * (1 + std::cos(kPi * (af - edge) / (fs - edge)));
    return h;
  }

  // Which scatterers the radar sees during frame k, with their frame-constant amplitude factors.
  void select_visible(std::uint64_t k) {
    t_mid = frame_start(k) + active / 2;
    const RigState radar = attached(body.state(t_mid), mount);
    dynamic.clear();
    scene.dynamic_scatterers(t_mid, dynamic);
    const double range_cut = max_range * 1.01 + 0.1;  // the IF band ends there (with Doppler margin)
    near_occluders.clear();
    near_cylinders.clear();
    if (options.occlusion) scene.nearby(radar.position, range_cut, near_occluders, near_cylinders);
    // A scatterer whose coherent SNR over a whole frame would be below -30 dB changes nothing.
    const double min_amp = 0.03 * options.noise_rms_lsb / std::sqrt(static_cast<double>(derived.samples_per_frame));
    n_visible = 0;
    auto consider = [&](const Scatterer& s) {
      const Eigen::Vector3d d = s.position - radar.position;
      const double r2 = d.squaredNorm();
      if (r2 < options.min_range_m * options.min_range_m || r2 > range_cut * range_cut) return;
      const double r = std::sqrt(r2);
      const Eigen::Vector3d u = d / r;
      const Eigen::Vector3d ur = radar.rotation.transpose() * u;
      if (ur.x() <= 1e-9) return;  // behind the radar or outside +-90 deg azimuth
      double rcs = s.rcs_m2;
      if (s.normal.squaredNorm() > 0) {
        const double cos_inc = -s.normal.dot(u);
        if (cos_inc <= 0) return;  // back face
        rcs *= std::pow(cos_inc, s.incidence_exponent);
      }
      if (rcs <= 0) return;
      const double theta = std::atan2(ur.y(), ur.x()), phi = std::asin(std::clamp(ur.z(), -1.0, 1.0));
      const double pattern = options.beam_pattern(theta, phi);
      const double rdot = u.dot(s.velocity - radar.velocity);
      const double tau = 2 * r / kC, tau_dot = 2 * rdot / kC;
      const std::complex<double> h = if_response(slope * tau * (1 - tau_dot) + fc * tau_dot);
      const std::complex<double> amp = amp_k * std::sqrt(rcs) * pattern * h;
      if (std::abs(amp) / r2 < min_amp) return;
      if (!scene.line_of_sight(radar.position, s, near_occluders, near_cylinders)) return;
      const std::size_t i = n_visible++;
      px[i] = s.position.x(), py[i] = s.position.y(), pz[i] = s.position.z();
      vx[i] = s.velocity.x(), vy[i] = s.velocity.y(), vz[i] = s.velocity.z();
      ax[i] = s.acceleration.x(), ay[i] = s.acceleration.y(), az[i] = s.acceleration.z();
      base_re[i] = static_cast<float>(amp.real());
      base_im[i] = static_cast<float>(amp.imag());
    };
    for (const Scatterer& s : scene.static_scatterers()) consider(s);
    for (const Scatterer& s : dynamic) consider(s);
  }

  // Range, range rate and direction of every visible scatterer at the reference time of chirp
  // (loop, slot), turned into the tone's phase, frequency and amplitude.
  void chirp_geometry(std::uint64_t k, int loop, int slot, ChirpGeometry& g) const {
    const double t = chirp_time(k, loop, slot);
    const RigState radar = attached(body.state(t), mount);
    detail::GeometryInput in;
    in.count = n_visible;
    in.px = px.data(), in.py = py.data(), in.pz = pz.data();
    in.vx = vx.data(), in.vy = vy.data(), in.vz = vz.data();
    in.ax = ax.data(), in.ay = ay.data(), in.az = az.data();
    in.amp_re = base_re.data(), in.amp_im = base_im.data();
    in.dt = t - t_mid;
    for (int i = 0; i < 3; ++i) {
      in.radar_pos[i] = radar.position[i];
      in.radar_vel[i] = radar.velocity[i];
      in.radar_y[i] = radar.rotation(i, 1);
      in.radar_z[i] = radar.rotation(i, 2);
    }
    in.slope = slope, in.fc = fc, in.inv_fs = 1 / fs;
    in.tx_azimuth = tx_az[slot], in.tx_elevation = tx_el[slot];
    detail::chirp_geometry(in, {g.psi.data(), g.x.data(), g.uy.data(), g.uz.data(), g.amp_re.data(), g.amp_im.data()});
  }

  // One chirp by the NUFFT: 16 (or 4) RX rows of samples into `out` ([rx][sample]).
  void chirp_fast(std::uint64_t k, int loop, int slot, Scratch& sc, std::complex<float>* out) const {
    ChirpGeometry& g = sc.geo;
    chirp_geometry(k, loop, slot, g);
    float* grid_re = sc.grid_re.data();
    float* grid_im = sc.grid_im.data();
    std::fill(sc.grid_re.begin(), sc.grid_re.end(), 0.0f);
    std::fill(sc.grid_im.begin(), sc.grid_im.end(), 0.0f);
    detail::SpreadInput in;
    in.count = n_visible;
    in.psi = g.psi.data(), in.x = g.x.data(), in.uy = g.uy.data(), in.uz = g.uz.data();
    in.amp_re = g.amp_re.data(), in.amp_im = g.amp_im.data();
    in.n_rx = n_rx;
    in.rx_azimuth = rx_az.data(), in.rx_elevation = rx_el.data();
    in.kernel_coefficients = kernel.coefficients();
    in.kernel_degree = detail::SpreadKernel::kDegree;
    in.grid_size = grid_size;
    in.stride = static_cast<std::size_t>(grid_stride);
    in.scratch_re = sc.c_re.data(), in.scratch_im = sc.c_im.data();
    detail::spread_scatterers(in, grid_re, grid_im);
    if (options.leakage_amplitude_lsb > 0)
      detail::spread_tone(leak_x, leak_re.data() + slot * n_rx, leak_im.data() + slot * n_rx, n_rx,
                          kernel.coefficients(), detail::SpreadKernel::kDegree, grid_size,
                          static_cast<std::size_t>(grid_stride), grid_re, grid_im);

    const int pad = kTaps / 2;
    for (int r = 0; r < n_rx; ++r) {
      float* re = grid_re + static_cast<std::size_t>(r) * grid_stride;
      float* im = grid_im + static_cast<std::size_t>(r) * grid_stride;
      // Fold the padding back onto the periodic grid, then transform in place.
      for (int i = 0; i < pad; ++i) {
        re[grid_size + i] += re[i];  // grid points -pad..-1 -> G-pad..G-1
        im[grid_size + i] += im[i];
        re[pad + i] += re[grid_size + pad + i];  // grid points G..G+pad-1 -> 0..pad-1
        im[pad + i] += im[grid_size + pad + i];
      }
      re += pad;
      im += pad;
      fft.run(re, im);
      const float gr = chan_re[slot * n_rx + r], gi = chan_im[slot * n_rx + r];
      std::complex<float>* o = out + static_cast<std::size_t>(r) * n_samples;
      for (int n = 0; n < n_samples; ++n) {
        const int at = fft.output((n - half + grid_size) & (grid_size - 1));
        const float yr = re[at] * deconv[n], yi = im[at] * deconv[n];
        o[n] = std::complex<float>(yr * gr - yi * gi, yr * gi + yi * gr);
      }
    }
  }

  // Complex white Gaussian noise for one loop, from its own random stream (so the result does
  // not depend on which thread makes which loop).
  void add_noise(std::uint64_t k, int loop, std::complex<float>* data, std::size_t count, Scratch& sc) const {
    detail::Random rng(detail::stream_seed(seed, kNoiseStream, k, static_cast<std::uint64_t>(loop)));
    const float sigma = static_cast<float>(options.noise_rms_lsb);
    float* out = reinterpret_cast<float*>(data);  // std::complex<float> is float[2]
    std::uint64_t* bits = sc.random.data();
    for (std::size_t done = 0; done < count; done += kNoiseBlock) {
      const std::size_t n = std::min(kNoiseBlock, count - done);
      for (std::size_t i = 0; i < n; ++i) bits[i] = rng.bits();
      detail::add_gaussian_noise(bits, n, sigma, out + 2 * done);
    }
  }

  void run_frame(std::uint64_t k, AdcCube& cube) {
    const std::size_t row = static_cast<std::size_t>(n_rx) * n_samples;
    const std::size_t loop_size = row * n_tx;
    for (Scratch& s : scratch) s.saturated = 0, s.max_abs = 0;
    auto job = [&](int worker) {
      Scratch& sc = scratch[static_cast<std::size_t>(worker)];
      for (int m = worker; m < loops; m += pool.size()) {
        std::complex<float>* base = cube.data.data() + m * loop_size;
        for (int slot = 0; slot < n_tx; ++slot) chirp_fast(k, m, slot, sc, base + slot * row);
        if (options.thermal_noise) add_noise(k, m, base, loop_size, sc);
        for (std::size_t i = 0; i < loop_size; ++i) {
          const double a = std::max(std::abs(base[i].real()), std::abs(base[i].imag()));
          sc.max_abs = std::max(sc.max_abs, a);
          if (a >= 32767.5) ++sc.saturated;
        }
      }
    };
    pool.run(job);
  }
};

double RadarModelOptions::beam_pattern(double theta, double phi) const {
  const double a = theta / (azimuth_beamwidth_deg * kPi / 180), e = phi / (elevation_beamwidth_deg * kPi / 180);
  return std::exp(-4 * std::log(2.0) * (a * a + e * e));
}

double RadarModelOptions::elevation_power_sigma_sin() const {
  return std::sin(elevation_beamwidth_deg * kPi / 180 / (4 * std::sqrt(std::log(2.0))));
}

RadarSimulator::RadarSimulator(const RadarConfig& config, const RadarModelOptions& options, const Scene& scene,
                               const Motion& body, const Mount& radar_mount, std::uint64_t seed, int threads)
    : impl_(std::make_unique<Impl>(config, options, scene, body, radar_mount, seed, threads)) {}

RadarSimulator::~RadarSimulator() = default;

const RadarConfig& RadarSimulator::config() const { return impl_->config; }
const RadarDerived& RadarSimulator::derived() const { return impl_->derived; }
double RadarSimulator::frame_start(std::uint64_t k) const { return impl_->frame_start(k); }
double RadarSimulator::frame_completion(std::uint64_t k) const { return impl_->frame_start(k) + impl_->active; }
double RadarSimulator::chirp_reference_time(std::uint64_t k, int loop, int slot) const {
  return impl_->chirp_time(k, loop, slot);
}
double RadarSimulator::amplitude_1m2_at_1m() const { return impl_->amp_k; }

std::uint64_t RadarSimulator::frames_until(double t) const {
  const double first_done = impl_->options.first_frame_s + impl_->active;
  if (t < first_done) return 0;
  return static_cast<std::uint64_t>(std::floor((t - first_done) / impl_->period + 1e-9)) + 1;
}

FrameStats RadarSimulator::simulate(std::uint64_t k, AdcCube& cube) {
  Impl& d = *impl_;
  if (cube.loops != d.loops || cube.slots != d.n_tx || cube.rx != d.n_rx || cube.samples != d.n_samples)
    cube = AdcCube::for_config(d.config);
  d.select_visible(k);
  d.run_frame(k, cube);
  FrameStats stats;
  stats.visible_scatterers = d.n_visible;
  for (const auto& s : d.scratch) {
    stats.saturated_samples += s.saturated;
    stats.max_abs_sample = std::max(stats.max_abs_sample, s.max_abs);
  }
  return stats;
}

void RadarSimulator::simulate_direct(std::uint64_t k, AdcCube& cube) {
  Impl& d = *impl_;
  cube = AdcCube::for_config(d.config);
  d.select_visible(k);
  Impl::ChirpGeometry g;
  g.reserve(d.n_visible);
  std::vector<std::complex<double>> acc(static_cast<std::size_t>(d.n_samples));
  for (int m = 0; m < d.loops; ++m) {
    for (int slot = 0; slot < d.n_tx; ++slot) {
      d.chirp_geometry(k, m, slot, g);
      for (int r = 0; r < d.n_rx; ++r) {
        std::fill(acc.begin(), acc.end(), 0.0);
        auto add_tone = [&](std::complex<double> c, double x) {
          for (int n = 0; n < d.n_samples; ++n) acc[n] += c * std::polar(1.0, 2 * kPi * x * (n - d.half));
        };
        for (std::size_t i = 0; i < d.n_visible; ++i) {
          const double ph = g.psi[i] - (d.rx_az[r] * g.uy[i] + d.rx_el[r] * g.uz[i]);
          const std::complex<double> amp(g.amp_re[i], g.amp_im[i]);
          add_tone(amp * std::polar(1.0, 2 * kPi * ph), g.x[i]);
        }
        const std::size_t ch = static_cast<std::size_t>(slot) * d.n_rx + r;
        if (d.options.leakage_amplitude_lsb > 0) add_tone({d.leak_re[ch], d.leak_im[ch]}, d.leak_x);
        const std::complex<double> gain(d.chan_re[ch], d.chan_im[ch]);
        for (int n = 0; n < d.n_samples; ++n) cube.at(m, slot, r, n) = std::complex<float>(acc[n] * gain);
      }
    }
  }
}

}  // namespace rsrio::sim
