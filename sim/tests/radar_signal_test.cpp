// The radar signal model checked from the outside: a single point scatterer against the textbook
// FMCW formula (computed here, independently of the simulator's code path), the fast NUFFT path
// against direct summation, the thermal noise against its configured power.
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/sim/motion.hpp"
#include "rsrio/sim/radar_simulator.hpp"
#include "rsrio/sim/scene.hpp"

using namespace rsrio;
using namespace rsrio::sim;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kC = 299'792'458.0;

// A scene with exactly one isotropic point at p.
SceneOptions one_point(const Eigen::Vector3d& p, double rcs) {
  SceneOptions s;
  ClutterOptions c;
  c.region = Eigen::Vector4d(p.x(), p.y(), p.x(), p.y());
  c.z_min_m = c.z_max_m = p.z();
  c.count = 1;
  c.rcs_m2 = rcs;
  s.clutter.push_back(c);
  return s;
}

RadarModelOptions clean_model() {
  RadarModelOptions m;
  m.thermal_noise = false;
  m.leakage_amplitude_lsb = 0;
  m.if_highpass_khz = 0;
  m.if_passband_fraction = 1.0;
  m.first_frame_s = 0.25;
  return m;
}

struct Textbook {
  // Everything from the configuration, written out from the FMCW formulas.
  double f0, slope, fs, fc, tc, idle, t_adc, d, active;
  // The array phases are referenced to the phase centre (the radar frame's origin): the mean over
  // the channels of the TX-RX midpoints, so the mean TX plus the mean RX position (element units).
  double centre_a = 0, centre_e = 0;
  int n_tx, n_rx, n_samples;
  explicit Textbook(const RadarConfig& c) {
    f0 = c.chirp.start_frequency_ghz * 1e9;
    slope = c.chirp.slope_mhz_per_us * 1e12;
    fs = c.chirp.adc_sample_rate_ksps * 1e3;
    n_samples = c.chirp.samples_per_chirp;
    t_adc = c.chirp.adc_start_time_us * 1e-6;
    idle = c.chirp.idle_time_us * 1e-6;
    tc = (c.chirp.idle_time_us + c.chirp.ramp_end_time_us) * 1e-6;
    fc = f0 + slope * (t_adc + n_samples / (2 * fs));
    d = 0.5 * fc / (c.array.design_frequency_ghz * 1e9);
    n_tx = static_cast<int>(c.tx_order.size());
    n_rx = static_cast<int>(c.array.rx_azimuth.size());
    active = c.loops * n_tx * tc;
    for (const int tx : c.tx_order) {
      centre_a += c.array.tx_azimuth[tx] / static_cast<double>(n_tx);
      centre_e += c.array.tx_elevation[tx] / static_cast<double>(n_tx);
    }
    for (int r = 0; r < n_rx; ++r) {
      centre_a += c.array.rx_azimuth[r] / static_cast<double>(n_rx);
      centre_e += c.array.rx_elevation[r] / static_cast<double>(n_rx);
    }
  }
};

double wrap(double a) { return std::remainder(a, 2 * kPi); }

}  // namespace

TEST_CASE("sim: a point scatterer's IF samples follow the textbook FMCW TDM-MIMO model", "[radar][signal]") {
  for (const char* preset : {"mmwcas", "xwr1843"}) {
    INFO("preset " << preset);
    const RadarConfig config = radar_preset(preset);
    const Textbook tb(config);
    // The body moves at constant velocity with a fixed heading; the radar sits on it with a lever
    // arm and a small rotation, so range rate, TDM offsets and spatial phases are all non-trivial.
    const Eigen::Vector3d start(0.3, -0.2, 1.0), velocity(0.7, 0.25, 0.0);
    const Eigen::Matrix3d body_rot = rotation_from_rpy(0.0, 0.0, 0.2);
    const LinearMotion body(start, velocity, body_rot, 10.0);
    Mount mount;
    mount.translation = Eigen::Vector3d(0.05, 0.02, 0.03);
    mount.rotation = rotation_from_rpy(0.02, -0.03, 0.05);
    const Eigen::Vector3d target(5.2, 2.4, 1.6);  // ~5 m, 20 deg left, 7 deg up
    const Scene scene(one_point(target, 1.0));
    const double rcs = scene.static_scatterers().at(0).rcs_m2;
    const RadarModelOptions model = clean_model();
    RadarSimulator sim(config, model, scene, body, mount, 11, 2);
    AdcCube cube;
    const std::uint64_t frame = 3;
    const FrameStats stats = sim.simulate(frame, cube);
    REQUIRE(stats.visible_scatterers == 1);

    // The radar's pose at any time, computed here.
    const Eigen::Matrix3d r_rad = body_rot * mount.rotation;
    auto radar_pos = [&](double t) { return Eigen::Vector3d(start + velocity * t + body_rot * mount.translation); };
    const double frame_start = model.first_frame_s + frame * config.frame_period_ms * 1e-3;

    // The radar equation with the model's figures.
    const double lambda = kC / tb.fc;
    const double snr = std::pow(10, (model.tx_power_dbm - 30) / 10) * std::pow(10, model.tx_gain_dbi / 10) *
                       std::pow(10, model.rx_gain_dbi / 10) * lambda * lambda /
                       (std::pow(4 * kPi, 3) * std::pow(10, model.system_loss_db / 10) * 1.380649e-23 * 290 *
                        std::pow(10, model.noise_figure_db / 10) * tb.fs);
    const double k_amp = model.noise_rms_lsb * std::sqrt(snr);
    CHECK(std::abs(sim.amplitude_1m2_at_1m() / k_amp - 1) < 1e-12);
    // Antenna pattern at the middle of the frame.
    const double t_mid = frame_start + tb.active / 2;
    const Eigen::Vector3d u_mid = r_rad.transpose() * (target - radar_pos(t_mid)).normalized();
    const double theta = std::atan2(u_mid.y(), u_mid.x()), phi = std::asin(u_mid.z());
    const double bw_az = model.azimuth_beamwidth_deg * kPi / 180, bw_el = model.elevation_beamwidth_deg * kPi / 180;
    const double pattern = std::exp(-4 * std::log(2.0) * (std::pow(theta / bw_az, 2) + std::pow(phi / bw_el, 2)));

    const int loops = config.loops;
    struct Index {
      int loop, slot, rx, sample;
    };
    const std::vector<Index> picks = {{0, 0, 0, tb.n_samples / 2},
                                      {loops - 1, tb.n_tx - 1, tb.n_rx - 1, tb.n_samples / 2},
                                      {loops / 2, 1, 2, 0},
                                      {loops / 3, tb.n_tx / 2, tb.n_rx / 2, tb.n_samples - 1},
                                      {1, tb.n_tx - 2, 1, 17}};
    for (const Index& ix : picks) {
      INFO("loop " << ix.loop << " slot " << ix.slot << " rx " << ix.rx << " sample " << ix.sample);
      // Sample time: slot start + idle + ADC start + n / fs; the chirp's ramp starts after idle.
      const double t_slot = frame_start + (ix.loop * tb.n_tx + ix.slot) * tb.tc;
      const double t_ramp = ix.sample / tb.fs + tb.t_adc;  // time since ramp start
      const double t = t_slot + tb.idle + t_ramp;
      const Eigen::Vector3d rel = target - radar_pos(t);
      const double range = rel.norm();
      const double tau = 2 * range / kC;
      const Eigen::Vector3d u = r_rad.transpose() * rel.normalized();
      const int tx = config.tx_order[ix.slot];
      const double a = config.array.tx_azimuth[tx] + config.array.rx_azimuth[ix.rx] - tb.centre_a;
      const double e = config.array.tx_elevation[tx] + config.array.rx_elevation[ix.rx] - tb.centre_e;
      // Textbook IF phase (mixer tx * conj(rx)) plus the narrowband array phase at the frequency
      // the echo was sent with, fc - S tau.
      const double phase = 2 * kPi * (tb.f0 * tau + tb.slope * tau * t_ramp - tb.slope * tau * tau / 2) -
                           2 * kPi * tb.d * (1 - tb.slope * tau / tb.fc) * (a * u.y() + e * u.z());
      const double amplitude = k_amp * std::sqrt(rcs) * pattern / (range * range);
      const std::complex<double> got = cube.at(ix.loop, ix.slot, ix.rx, ix.sample);
      CHECK(std::abs(std::abs(got) / amplitude - 1) < 2e-5);
      // At the chirp's reference sample the model is exact; elsewhere it neglects the chirp-rate
      // term S tau_dot t'^2 (documented bound).
      const double rdot = rel.normalized().dot(-velocity);
      const double tprime = (ix.sample - tb.n_samples / 2) / tb.fs;
      // ... and holds the direction for the ~26 us of the samples: the channel's array phase moves
      // by d (a du_y/dt + e du_z/dt) t' (documented bound).
      auto dir = [&](double tt) { return Eigen::Vector3d(r_rad.transpose() * (target - radar_pos(tt)).normalized()); };
      const Eigen::Vector3d u_rate = (dir(t + 1e-3) - dir(t - 1e-3)) / 2e-3;
      const double bound = 2 * kPi * tb.slope * std::abs(2 * rdot / kC) * tprime * tprime +
                           2 * kPi * tb.d * std::abs(a * u_rate.y() + e * u_rate.z()) * std::abs(tprime);
      CHECK(std::abs(wrap(std::arg(got) - phase)) < 3e-5 + 1.01 * bound);
    }
  }
}

TEST_CASE("sim: Doppler and TDM phases give positive Doppler for a receding target", "[radar][signal]") {
  const RadarConfig config = radar_preset("mmwcas");
  const Textbook tb(config);
  // Radar backs away from a target straight ahead at 0.5 m/s: v_r = +0.5 (receding).
  const double v = 0.5;
  const LinearMotion body(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(-v, 0, 0), Eigen::Matrix3d::Identity(), 10);
  const Scene scene(one_point(Eigen::Vector3d(6, 0, 1), 1.0));
  RadarSimulator sim(config, clean_model(), scene, body, Mount{}, 1, 1);
  AdcCube cube;
  sim.simulate(0, cube);
  const int n = tb.n_samples / 2;
  // Phase advance per loop (same slot) and per slot, expected 2 v Tc N_tx / lambda cycles and
  // 2 v Tc / lambda cycles (plus the change of the spatial phase: none at boresight).
  const double lambda = kC / tb.fc;
  const std::complex<float> c00 = cube.at(0, 0, 0, n), c10 = cube.at(1, 0, 0, n), c01 = cube.at(0, 1, 0, n);
  const double per_loop = std::arg(std::complex<double>(c10) * std::conj(std::complex<double>(c00)));
  const double per_slot = std::arg(std::complex<double>(c01) * std::conj(std::complex<double>(c00)));
  // Slot 1 fires another TX: remove its (boresight: zero) spatial phase difference.
  CHECK(std::abs(wrap(per_loop - 2 * kPi * 2 * v * tb.tc * tb.n_tx / lambda)) < 1e-4);
  CHECK(std::abs(wrap(per_slot - 2 * kPi * 2 * v * tb.tc / lambda)) < 1e-4);
  CHECK(per_loop > 0);  // increasing phase: positive frequency under a forward FFT
}

TEST_CASE("sim: the beam's power is half each way at half a beamwidth, and its elevation sigma fits it", "[radar][signal]") {
  RadarModelOptions m;
  m.azimuth_beamwidth_deg = 120;
  m.elevation_beamwidth_deg = 30;
  const double deg = kPi / 180;
  // The pattern is on the amplitude, both ways: power 1/2 * 1/2 at half a beamwidth.
  CHECK(std::abs(std::pow(m.beam_pattern(60 * deg, 0), 2) - 0.25) < 1e-12);
  CHECK(std::abs(std::pow(m.beam_pattern(0, -15 * deg), 2) - 0.25) < 1e-12);
  CHECK(m.beam_pattern(0, 0) == 1.0);
  // What the renderers take: the two-way power over elevation as exp(-w^2 / (2 s^2)) in
  // w = sin(elevation); at w = s it is exp(-1/2).
  const double s = m.elevation_power_sigma_sin();
  CHECK(std::abs(s - 0.1566) < 1e-4);
  CHECK(std::abs(std::pow(m.beam_pattern(0, std::asin(s)), 2) - std::exp(-0.5)) < 1e-12);
  m.elevation_beamwidth_deg = 60;
  CHECK(m.elevation_power_sigma_sin() > 1.9 * s);
}

TEST_CASE("sim: the wideband array effect stays inside the documented bound", "[radar][signal]") {
  // The simulator takes the spatial phase at fc. The exact path difference (p_tx + p_rx) . u also
  // enters the beat term S tau t: compare with the fully wideband textbook formula.
  const RadarConfig config = radar_preset("mmwcas");
  const Textbook tb(config);
  const StaticMotion body(Eigen::Vector3d(0, 0, 1), Eigen::Matrix3d::Identity());
  const Eigen::Vector3d target(3.0, -2.5, 1.2);
  const Scene scene(one_point(target, 1.0));
  RadarSimulator sim(config, clean_model(), scene, body, Mount{}, 1, 2);
  AdcCube cube;
  sim.simulate(0, cube);
  const Eigen::Vector3d u = (target - Eigen::Vector3d(0, 0, 1)).normalized();
  const double range = (target - Eigen::Vector3d(0, 0, 1)).norm();
  const double half_wl_design = kC / (config.array.design_frequency_ghz * 1e9) / 2;
  double worst_excess = 0;
  for (int slot = 0; slot < tb.n_tx; ++slot)
    for (int rx = 0; rx < tb.n_rx; ++rx)
      for (int n : {0, tb.n_samples / 2, tb.n_samples - 1}) {
        const int tx = config.tx_order[slot];
        const double path =
            2 * range - half_wl_design * ((config.array.tx_azimuth[tx] + config.array.rx_azimuth[rx] - tb.centre_a) * u.y() +
                                          (config.array.tx_elevation[tx] + config.array.rx_elevation[rx] - tb.centre_e) * u.z());
        const double tau = path / kC, t_ramp = tb.t_adc + n / tb.fs;
        const double exact = 2 * kPi * (tb.f0 * tau + tb.slope * tau * t_ramp - tb.slope * tau * tau / 2);
        const double diff = std::abs(wrap(std::arg(std::complex<double>(cube.at(0, slot, rx, n))) - exact));
        const double tau_p = (2 * range - path) / kC;
        const double bound = 2 * kPi * tb.slope * std::abs(tau_p) * std::abs(n - tb.n_samples / 2) / tb.fs +
                             kPi * tb.slope * tau_p * tau_p;
        worst_excess = std::max(worst_excess, diff - bound);
      }
  CHECK(worst_excess < 1e-4);
}

TEST_CASE("sim: the NUFFT path equals direct summation", "[radar][signal]") {
  for (const char* preset : {"mmwcas", "xwr1843"}) {
    INFO("preset " << preset);
    RadarConfig config = radar_preset(preset);
    config.loops = 3;  // the direct sum is slow
    SceneOptions so;
    ClutterOptions c;
    c.region = Eigen::Vector4d(0.5, -6, 17, 6);
    c.count = 40;
    c.z_min_m = 0.2;
    c.z_max_m = 2.0;
    c.rcs_m2 = 0.5;
    so.clutter.push_back(c);
    PersonOptions p;
    p.path = {Eigen::Vector2d(3, -2), Eigen::Vector2d(4, 3)};
    so.people.push_back(p);
    const Scene scene(so);
    const CircularMotion body(Eigen::Vector3d(0, 1, 1), 1.0, 0.4, 100);  // turning: per-chirp directions change
    RadarModelOptions model = clean_model();
    model.leakage_amplitude_lsb = 30;
    model.if_highpass_khz = 175;
    model.if_passband_fraction = 0.9;
    model.channel_phase_error_deg = 5;
    model.channel_gain_error_db = 0.5;
    RadarSimulator sim(config, model, scene, body, Mount{}, 5, 2);
    AdcCube fast, direct;
    const FrameStats stats = sim.simulate(2, fast);
    sim.simulate_direct(2, direct);
    REQUIRE(stats.visible_scatterers > 10);
    double scale = 0, worst = 0;
    for (std::size_t i = 0; i < direct.data.size(); ++i) scale = std::max(scale, double(std::abs(direct.data[i])));
    for (std::size_t i = 0; i < direct.data.size(); ++i)
      worst = std::max(worst, double(std::abs(fast.data[i] - direct.data[i])));
    INFO("largest sample " << scale << " LSB, largest difference " << worst << " LSB");
    CHECK(worst < 2e-6 * scale * std::sqrt(double(stats.visible_scatterers)));
  }
}

TEST_CASE("sim: thermal noise has the configured power and is complex Gaussian", "[radar][noise]") {
  const RadarConfig config = radar_preset("mmwcas");
  const Scene scene(SceneOptions{});
  const StaticMotion body(Eigen::Vector3d(0, 0, 1), Eigen::Matrix3d::Identity());
  RadarModelOptions model;
  model.noise_rms_lsb = 12.0;
  model.leakage_amplitude_lsb = 0;
  RadarSimulator sim(config, model, scene, body, Mount{}, 9, 2);
  AdcCube cube;
  sim.simulate(0, cube);
  double p = 0, p4 = 0, re2 = 0, mean_re = 0, mean_im = 0;
  for (const auto& x : cube.data) {
    const double a2 = std::norm(std::complex<double>(x));
    p += a2;
    p4 += a2 * a2;
    re2 += double(x.real()) * x.real();
    mean_re += x.real();
    mean_im += x.imag();
  }
  const double n = static_cast<double>(cube.data.size());
  p /= n, p4 /= n, re2 /= n, mean_re /= n, mean_im /= n;
  const double sigma2 = 144.0;
  CHECK(std::abs(p / sigma2 - 1) < 0.01);        // estimate's std: 1 / sqrt(786432) = 0.11 %
  CHECK(std::abs(re2 / (sigma2 / 2) - 1) < 0.01); // I and Q share it equally
  CHECK(std::abs(mean_re) < 0.1);
  CHECK(std::abs(mean_im) < 0.1);
  CHECK(std::abs(p4 / (sigma2 * sigma2) - 2) < 0.05);  // E|n|^4 = 2 sigma^4 for a complex Gaussian
}

TEST_CASE("sim: the IF filters shape the range response", "[radar][signal]") {
  const RadarConfig config = radar_preset("mmwcas");
  const StaticMotion body(Eigen::Vector3d(0, 0, 1), Eigen::Matrix3d::Identity());
  const double max_range = derive(config).max_range_m;
  auto amplitude = [&](double range, double hpf_khz) {
    const Scene scene(one_point(Eigen::Vector3d(range, 0, 1), 1.0));
    RadarModelOptions model = clean_model();
    model.if_highpass_khz = hpf_khz;
    model.if_passband_fraction = 0.9;
    RadarSimulator sim(config, model, scene, body, Mount{}, 1, 1);
    AdcCube cube;
    sim.simulate(0, cube);
    return std::abs(cube.at(0, 0, 0, 64)) * range * range * std::sqrt(1.0 / scene.static_scatterers()[0].rcs_m2);
  };
  const double flat = amplitude(5.0, 0);
  // First-order high-pass at 175 kHz: beat 2 S R / c = 267 kHz at 1 m -> |H| = 0.836.
  const double fb = 2 * 40e12 * 1.0 / kC;
  CHECK(std::abs(amplitude(1.0, 175) / flat - (fb / 175e3) / std::sqrt(1 + std::pow(fb / 175e3, 2))) < 1e-4);
  // Beyond the sampled band nothing comes through.
  CHECK(amplitude(max_range * 1.02, 0) == 0.0);
  CHECK(std::abs(amplitude(0.5 * max_range, 0) / flat - 1) < 1e-5);
}
