// Raw-ADC FMCW TDM-MIMO radar simulation: the IF samples a TI radar would digitise, for every
// (loop, TDM slot, RX, sample) of a frame, from a Scene seen by a radar moving along a Motion.
//
// ---------------------------------------------------------------------------------------------
// SIGNAL CONVENTION (what a point target produces in the AdcCube, before noise and int16)
// ---------------------------------------------------------------------------------------------
// Radar frame: x boresight, y left, z up (FLU), origin at the array's phase centre: the mean over
// the channels of the TX-RX midpoints, i.e. the mean TX position plus the mean RX position in
// virtual-array indices (a_c, e_c). There every channel's Doppler (the slow-time change of its
// array phase) and the array's angle refer to one point. Antenna positions (RadarConfig::array,
// integers in half-wavelengths at design_frequency_ghz) lie along +y (azimuth index a,
// increasing to the radar's LEFT) and +z (elevation index e, increasing UP). The direction to the target in the radar frame is the unit vector u, with
// u_y = cos(phi) sin(theta), u_z = sin(phi): azimuth theta positive to the left, elevation phi
// positive up.
//
// Mixer tx * conj(rx) (reference/rio.md Sec. 7.1): a delay tau gives the IF phase
//   2 pi (f0 tau + S tau t - S tau^2 / 2), t = time since the chirp's ramp start,
// i.e. a positive beat frequency S tau for a positive range, as TI's complex baseband delivers.
//
// Timing: chirp (loop m, slot k) starts at t_mk = frame_start + (m N_tx + k) Tc, Tc = idle +
// ramp end, with its idle time; the ramp starts at t_mk + idle and ADC sample n is taken at
// t_mk + idle + t_adc + n / fs. The geometry of every chirp is evaluated exactly at its own
// reference time t_ref = t_mk + idle + t_adc + (N/2) / fs (sample N/2), so
// the motion between TDM slots, between loops and the range migration within the frame are in
// the signal; within one chirp's samples (25.6 us for mmwcas) the range is linear in time.
//
// For a point at range R and range rate v_r (both at t_ref; v_r > 0 receding), direction u:
//   tau = 2 R / c,  tau_dot = 2 v_r / c
//   fc  = f0 + S (t_adc + N / (2 fs))                        (RadarDerived::center_frequency_hz)
//   x   = (S tau (1 - tau_dot) + fc tau_dot) / fs             [cycles / sample: beat + Doppler]
//   psi = fc tau - S tau^2 / 2 - d (1 - S tau / fc) (a_kr u_y + e_kr u_z)      [cycles]
//   cube(m, k, r, n) = A exp(j 2 pi (psi + x (n - N/2)))
// where d = RadarDerived::element_spacing_wavelengths = 0.5 fc / f_design, a_kr and e_kr the
// virtual channel's azimuth / elevation index from the phase centre
// (tx_azimuth[tx_order[k]] + rx_azimuth[r] - a_c, ...).
//   A = K sqrt(rcs cos^p(incidence)) G(theta, phi) H_IF(x fs) / R^2   (LSB, radar equation)
//   K = noise_rms_lsb sqrt(Pt Gt Gr lambda^2 / ((4 pi)^3 L k T0 F fs)),
//   G = exp(-4 ln2 ((theta / bw_az)^2 + (phi / bw_el)^2))   (two-way voltage = one-way power pattern)
//   H_IF = first-order high-pass (j f/f_hp) / (1 + j f/f_hp) times a flat band to
//          if_passband_fraction fs, cosine taper to fs (the decimation filter; nothing beyond).
//
// Consequences for a standard pipeline of forward FFTs (exp(-j 2 pi k n / N)):
//  * range FFT over n: peak at bin k = N_fft x, i.e. R = k c fs / (2 S N_fft) (positive bins);
//  * the phase advances by 2 v_r N_tx Tc / lambda cycles per loop, so the Doppler FFT over loops
//    peaks at k = v_r / v_res with v_res = lambda / (2 N_loops N_tx Tc): POSITIVE DOPPLER =
//    RECEDING; a static point seen from a radar moving with velocity v (radar frame) has
//    v_r = -u . v;
//  * consecutive TDM slots of one loop differ by 2 v_r Tc / lambda cycles (the TDM-MIMO phase
//    to compensate);
//  * angle FFT over the azimuth index a: peak at k = -N_angle d u_y (signed): a target on the
//    radar's LEFT (u_y > 0) appears at NEGATIVE bins, sin(theta) cos(phi) = -k / (N_angle d).
//    Same for elevation with u_z.
//
// (The factor 1 - S tau / fc: the echo was sent tau earlier, at a lower frequency.)
//
// Approximations (bounded, documented so that nobody mistakes them for DSP artefacts):
//  * far field and narrowband array: the spatial phase is taken at the chirp's centre frequency;
//    the exact path difference p . u (p = the channel's TX + RX position) also shifts the beat
//    frequency per channel by S (p . u) / c, up to 2 pi S |p . u| N / (2 fs c) rad at the ends
//    of a chirp (about 1.8 rad for the cascade's outermost channels at 90 deg, 0.2 rad for
//    xwr1843), plus pi S (p . u / c)^2 (< 0.1 mrad);
//  * the phase within one chirp is linear in n: the neglected chirp-rate term S tau_dot t'^2 is
//    below 2 pi S tau_dot (N / (2 fs))^2 (0.3 mrad at 1 m/s for mmwcas);
//  * the direction u is held during one chirp's samples: a channel's array phase would move by
//    2 pi d (a du_y/dt + e du_z/dt) t', up to 3.5 mrad for the cascade's outermost channel at a
//    turn rate of 1 rad/s;
//  * the antenna pattern, RCS incidence factor, IF filter response and visibility are evaluated
//    once per frame, at its middle (frame_start + active time / 2); range, range rate and
//    direction per chirp.
//
// Noise: complex white Gaussian, E|n|^2 = noise_rms_lsb^2 per sample (I and Q each
// noise_rms_lsb / sqrt 2). TX-to-RX leakage: a fixed zero-Doppler return at leakage_range_m with
// a random phase per virtual channel. Optional channel gain / phase errors m_kr multiply each
// virtual channel; config() then carries the calibration 1 / m_kr a real calibration would give.
// int16 quantisation (round to nearest, saturate) happens in encode_frame().
//
// Speed: the sum over scatterers is evaluated per chirp and RX as a type-1 non-uniform FFT over
// the samples (exponential-of-semicircle kernel, 8 taps, oversampling 2: relative error ~1e-7,
// checked against direct summation in the tests), parallel over loops, no allocation per frame.
// The output does not depend on the number of threads.
#pragma once

#include <complex>
#include <cstdint>
#include <memory>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/sim/motion.hpp"
#include "rsrio/sim/scene.hpp"

namespace rsrio::sim {

/// Physics of the simulated radar front end (scenario section `radar_model`).
struct RadarModelOptions {
  double tx_power_dbm = 12.0;           // per TX (one at a time in TDM)
  double tx_gain_dbi = 10.0;            // antenna peak gains
  double rx_gain_dbi = 10.0;
  double noise_figure_db = 12.0;
  double system_loss_db = 3.0;
  double noise_rms_lsb = 10.0;          // thermal noise at the ADC: sets the digital scale
  bool thermal_noise = true;            // false: no noise (the scale stays)
  double azimuth_beamwidth_deg = 120.0;   // one-way half-power beamwidths (Gaussian beam)
  double elevation_beamwidth_deg = 30.0;
  double if_highpass_khz = 175.0;       // first-order IF high-pass corner (0: none)
  double if_passband_fraction = 0.9;    // flat IF band up to this fraction of fs (1: no taper)
  double leakage_amplitude_lsb = 20.0;  // TX-RX coupling at the ADC (0: none)
  double leakage_range_m = 0.06;
  double channel_gain_error_db = 0.0;   // RMS of per-channel gain errors (0: ideal)
  double channel_phase_error_deg = 0.0; // RMS of per-channel phase errors
  double min_range_m = 0.1;             // nearer scatterers are dropped (far field breaks down)
  bool occlusion = true;                // walls, box faces and pillars hide what is behind them
  double first_frame_s = 0.1;           // start of frame 0

  /// The antenna pattern on a return's amplitude, transmit and receive together, at azimuth theta
  /// and elevation phi (radians, radar frame): exp(-4 ln 2 ((theta / bw_az)^2 + (phi / bw_el)^2)),
  /// so that each way's power is half at half a beamwidth.
  double beam_pattern(double theta, double phi) const;
  /// The two-way power pattern over elevation, exp(-8 ln 2 (phi / bw_el)^2), as a Gaussian in
  /// sin(elevation): sin(bw_el / (4 sqrt(ln 2))), 0.157 for 30 deg. What the RA renderer's
  /// elevation gain and the RD renderer's elevation beam are for this radar.
  double elevation_power_sigma_sin() const;
};

/// What one frame contained.
struct FrameStats {
  std::size_t visible_scatterers = 0;
  std::size_t saturated_samples = 0;    // I or Q beyond int16 (will be clipped)
  double max_abs_sample = 0;
};

class RadarSimulator {
 public:
  /// `scene` and `body` must outlive the simulator. The radar frame is `radar_mount` on the body.
  /// Throws std::invalid_argument for an unusable configuration.
  RadarSimulator(const RadarConfig& config, const RadarModelOptions& options, const Scene& scene, const Motion& body,
                 const Mount& radar_mount, std::uint64_t seed, int threads = 2);
  ~RadarSimulator();
  RadarSimulator(const RadarSimulator&) = delete;
  RadarSimulator& operator=(const RadarSimulator&) = delete;

  /// The configuration the frames are made with (calibration filled in when channel errors are
  /// simulated).
  const RadarConfig& config() const;
  const RadarDerived& derived() const;

  /// Start of frame k's first chirp, s.
  double frame_start(std::uint64_t k) const;
  /// End of frame k's last chirp: when the capture hardware has the whole frame (its stamp), s.
  double frame_completion(std::uint64_t k) const;
  /// The reference time of chirp (loop, slot) of frame k: its sample N/2, s.
  double chirp_reference_time(std::uint64_t k, int loop, int slot) const;
  /// Number of frames that complete by time t.
  std::uint64_t frames_until(double t) const;

  /// Synthesises frame k (noise included, not quantised) into `cube`, reshaped if needed.
  FrameStats simulate(std::uint64_t k, AdcCube& cube);

  /// The same frame without noise by direct summation in double precision: slow, for tests of
  /// the fast path.
  void simulate_direct(std::uint64_t k, AdcCube& cube);

  /// Radar-equation amplitude (LSB, before the IF filter) of a 1 m^2 target at 1 m at boresight.
  double amplitude_1m2_at_1m() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsrio::sim
