// The MRIO-style radar-inertial frontend: IMU preintegration (GTSAM CombinedImuFactor with bias
// states) and one radar ego-velocity factor per radar frame, solved by Levenberg-Marquardt over a
// bounded window of states whose oldest state is marginalised into a linear prior (Debian's GTSAM
// 4.2 has no gtsam_unstable fixed-lag smoother, SPEC Sec. 3).
//
// Frames: world W is z-up with gravity (0, 0, -g); body B is the IMU; radar R sits at body_T_radar.
// Radar stamps are on the radar clock: IMU time = radar time + radar_time_offset_s.
#pragma once

#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <gtsam/geometry/Pose3.h>
#include <gtsam/navigation/CombinedImuFactor.h>
#include <gtsam/nonlinear/NonlinearFactorGraph.h>
#include <gtsam/nonlinear/Values.h>

#include "rsrio/rio/ego_velocity.hpp"

namespace rsrio::rio {

struct FrontendOptions {
  // IMU noise, continuous time (BMI055-class consumer MEMS by default).
  double gravity = 9.81;
  double accel_noise_density = 2.0e-3;   // m/s^2/sqrt(Hz)
  double gyro_noise_density = 2.0e-4;    // rad/s/sqrt(Hz)
  double accel_bias_random_walk = 3.0e-4;   // m/s^3/sqrt(Hz)
  double gyro_bias_random_walk = 2.0e-5;    // rad/s^2/sqrt(Hz)
  // GTSAM 4.2's PreintegrationCombinedParams::biasAccOmegaInt ("covariance of bias used as initial
  // estimate"), in the window's IMU factors. CombinedImuFactor's preintegration adds it to the
  // accelerometer's and the gyro's white-noise covariance at every sample (4.3 removed it,
  // borglab/gtsam PR #2199), so it is extra IMU noise, (m/s^2)^2/Hz and (rad/s)^2/Hz: GTSAM's
  // example value 1e-5 runs the window with a gyro of 3.2e-3 rad/s/sqrt(Hz), 16 times the 2e-4
  // above, and an accelerometer of 3.7e-3 m/s^2/sqrt(Hz), 1.9 times. With the IMU's own noise (0)
  // the window's tilt against gravity is 2-3 times better, but its heading jumps by up to
  // 0.8-2.4 deg within a second on the longer sequences (the whole window turning about the
  // world's origin: its marginals are linearised at older estimates; taking position and heading
  // out of them stops the jumps but lets the height drift; first_estimate_jacobians stops them and
  // keeps the tilt), and the backend ends worse on some sequences and better on others
  // (rio/RESULTS.md, splat/RESULTS.md, 2026-12-07). The whole-run batch, which has no marginals,
  // always takes the IMU's own noise.
  double bias_acc_omega_int = 1e-5;
  // First-estimate Jacobians (first_estimate_factor.hpp): the factors that still reach the state a
  // marginal prior was linearised on take their Jacobians at that state's estimate then, not at
  // later ones, so that the prior and they agree on the unobservable heading and position. With
  // bias_acc_omega_int 0 the heading then no longer jumps (sequence 4's largest change in a second
  // 0.12 deg against 0.82) and the tilt keeps its factor of 2; with 1e-5 it changes nothing that
  // shows. Off by default: the backend's end of run on it is mixed (sequence 4 better on both
  // draws of the noise, sequence 1's heading and sequence 3's translation worse; splat/RESULTS.md).
  bool first_estimate_jacobians = false;
  // How the signal runs between two IMU samples when it is integrated. kLinear: the straight line
  // through them, right for instantaneous samples (the simulator's; a MEMS IMU's output data are its
  // filter's value at the stamp). kHold: each sample held until the next (zero-order hold), which
  // integrates instantaneous samples half a sample period late (2.5 ms at 200 Hz: the heading
  // 0.13 deg behind in a 51 deg/s turn); right for an IMU whose sample is the mean of the interval
  // it starts.
  enum class ImuInterpolation { kLinear, kHold };
  ImuInterpolation imu_interpolation = ImuInterpolation::kLinear;
  // Radar.
  gtsam::Pose3 body_T_radar;                 // extrinsic
  double radar_time_offset_s = 0.0;
  double radar_velocity_sigma_scale = 1.0;   // inflate the ego-velocity covariance
  double huber_k = 1.345;                    // robust loss on the whitened radar error
  bool use_radar = true;                     // false: IMU only (the ablation)
  // Zero angular-rate update: yaw is not observable from ego-velocities (the lever arm is a few
  // centimetres), so an uncorrected gyro z bias turns straight into heading drift. Whenever the
  // radar says the rig stands (|v| below still_speed_mps) and the gyro agrees (mean rate below
  // still_gyro_rate from the bias believed so far), the mean gyro rate over the interval is a
  // measurement of the gyro bias (taken for an interval whose neighbours are still too).
  bool zero_rate_update = true;
  double still_speed_mps = 0.05;
  double still_gyro_rate = 0.01;             // rad/s, |mean gyro - believed bias| (3 sigma of a MEMS bias)
  double still_rate_sigma = 5e-4;            // rad/s, residual true rotation while standing
  int still_neighbours = 3;                  // still intervals needed on each side of one that counts
  // Position and heading are unobservable (only dead reckoning ties them to the start), and the
  // window re-estimates them with every new piece of evidence: a zero-rate update after a long drive
  // changes the believed gyro bias, and with it the whole heading history, by a degree and the
  // position by tens of centimetres in one frame. true: publish a continuous odometry (REP 105)
  // by carrying the re-estimate of the four unobservable degrees of freedom at each zero-rate
  // update forward as an offset (that frame moves by the motion the window estimates since the
  // previous one); roll and pitch stay absolute (gravity observes them), and between updates the
  // window's estimate is published as it is. false: the window's estimate always.
  bool continuous_odometry = true;
  // Published horizontal positions. false: the window's estimate of the newest state. true: the
  // previous published position plus the trapezoid of the two frames' published velocities, so that
  // they are the integral of the velocities the radar measures (along a corridor the window's
  // positions wander from that integral by a few mm/s for seconds at a time, splat/RESULTS.md
  // 2026-12-06; why is not found). Height stays the window's: the radar hardly sees the vertical
  // velocity, and its integral drifts (tenths of a metre over a few minutes: the SE(3) alignment
  // then tilts a run by a degree). Orientation and velocity are the window's either way.
  bool position_from_velocity = false;
  // Keep every factor and state of the run (besides the window) so that smooth_whole_run() can
  // solve the whole run as one batch at its end: what the window marginalised, linearised at its
  // estimate then, is re-linearised with everything measured after it (the accelerometer bias,
  // told from a tilt only by turns spread over the run). Its IMU factors carry the IMU's own noise
  // (no bias_acc_omega_int: without marginals its heading does not jump), preintegrated beside
  // the window's in the same walk over the samples. An end-of-run estimate (rsrio-replay's estimate_final.tum), not
  // causal; memory grows with the run (a few kB a frame), so not for rsriod.
  bool whole_run_smoother = false;
  // Window and priors.
  int window_states = 20;
  int lm_max_iterations = 15;
  double prior_rotation_sigma = 0.01;        // rad (roll/pitch from gravity are good, yaw is the gauge)
  double prior_position_sigma = 0.001;       // m
  double prior_velocity_sigma = 0.1;         // m/s
  double prior_accel_bias_sigma = 0.1;
  double prior_gyro_bias_sigma = 0.01;
  double init_imu_window_s = 0.2;            // IMU averaged for the initial roll and pitch
};

/// The config file's name of an ImuInterpolation ("linear", "hold"), and back; false for any other name.
const char* to_string(FrontendOptions::ImuInterpolation m);
[[nodiscard]] bool imu_interpolation_from_string(const std::string& name, FrontendOptions::ImuInterpolation& m);

struct ImuSample {
  double t = 0;  // s, IMU clock
  gtsam::Vector3 accel = gtsam::Vector3::Zero();  // specific force, m/s^2, body frame
  gtsam::Vector3 gyro = gtsam::Vector3::Zero();   // rad/s, body frame
};

/// A state as the window last estimated it, when it left the window (window_states frames after it
/// was published): smoothed by everything measured since, it does not change again. Its tilt is
/// better than the one published then, since a frame's radar noise pulls on roll and pitch until
/// later frames average it out (sequence 4: 0.065 deg RMS against 0.098 published). Not causal:
/// for an end-of-run trajectory (rsrio-replay's estimate_final.tum), not the odometry.
struct SettledState {
  double t = 0;               // radar clock: the t its frame was published with (to rounding)
  gtsam::Pose3 world_T_body;  // in the window's frame as the state leaves it
  gtsam::imuBias::ConstantBias bias;
};

/// One state of the whole run as smooth_whole_run() estimated it (in the window's frame: without
/// the continuous odometry's offsets).
struct SmoothedState {
  double t = 0;  // radar clock, the t its frame was published with
  gtsam::Pose3 world_T_body;
  gtsam::Vector3 velocity_world = gtsam::Vector3::Zero();
  gtsam::imuBias::ConstantBias bias;
};

struct FrontendState {
  double t = 0;                                  // radar clock
  gtsam::Pose3 world_T_body;
  gtsam::Vector3 velocity_world = gtsam::Vector3::Zero();
  gtsam::Vector3 angular_velocity_body = gtsam::Vector3::Zero();  // the gyro at t (interpolated) less the bias
  gtsam::imuBias::ConstantBias bias;
  gtsam::Matrix6 pose_covariance = gtsam::Matrix6::Identity();  // tangent [rotation, translation]
  bool radar_used = false;                       // an ego-velocity factor was added for this frame
  std::optional<SettledState> settled;           // the state that left the window at this frame
};

/// The attitude a later accelerometer-bias estimate gives a past state. The radar pins the
/// horizontal velocity, so the window measures the sum of the horizontal accelerometer bias and the
/// gravity that a tilt leaks into the accelerometer: until the rig turns they are one unknown, and
/// roll and pitch are off by (bias believed - true bias) / g (0.3-0.4 deg along sequence 3's first
/// corridor). Given the bias believed at the time and a later one (after turns have told the two
/// apart), returns world_T_body with its roll and pitch corrected by the difference; position
/// unchanged, heading to first order. A smoother's correction for an estimate that is not causal
/// (the end-of-run trajectory), not for the published odometry.
gtsam::Pose3 retilted(const gtsam::Pose3& world_T_body, const gtsam::Vector3& accel_bias_then,
                      const gtsam::Vector3& accel_bias_now, double gravity);

/// world_T_body turned by the smallest rotation (in the body frame, about an axis perpendicular to
/// up) that gives it attitude's tilt: its up vector in the body frame becomes attitude's, its
/// heading changes to second order in the tilt difference, its position not at all. What puts a
/// settled state's tilt on a published pose.
gtsam::Pose3 with_tilt_of(const gtsam::Pose3& world_T_body, const gtsam::Rot3& attitude);

class RioFrontend {
 public:
  explicit RioFrontend(const FrontendOptions& options = {});

  /// IMU samples in time order (IMU clock); older than the last state are ignored (counted).
  void add_imu(const ImuSample& sample);
  /// A radar frame at `t_radar` with its ego-velocity (rejected estimates add no radar factor).
  /// Returns the state at that time, or nullopt while it cannot start (no IMU yet).
  std::optional<FrontendState> add_radar(double t_radar, const EgoVelocity& ego);

  int states() const { return static_cast<int>(window_.size()); }
  std::uint64_t imu_ignored() const { return imu_ignored_; }
  std::uint64_t frames_without_radar() const { return frames_without_radar_; }
  std::uint64_t zero_rate_updates() const { return zero_rate_updates_; }
  /// What the window's IMU factors are preintegrated with (the options' noise as GTSAM takes it).
  const gtsam::PreintegrationCombinedParams& imu_params() const { return *params_; }
  /// ... and the whole-run batch's (the IMU's own noise: no biasAccOmegaInt).
  const gtsam::PreintegrationCombinedParams& whole_run_imu_params() const { return *whole_params_; }
  /// The information (1/rad^2) the window holds on a turn of all its states about the world's
  /// vertical through the origin: the heading's gauge, which no measurement observes. A consistent
  /// window holds what the first state's priors put there (1/prior_rotation_sigma^2, and its
  /// velocity's) less what the gyro's noise has blurred since; relinearising the factors of a
  /// marginal's state adds to it (first_estimate_jacobians).
  /// A diagnostic: linearises the window (1-2 ms).
  double heading_gauge_information() const;
  /// whole_run_smoother: every state of the run so far, solved as one batch over every factor added
  /// (Levenberg-Marquardt from the window's estimates, at most max_iterations), in time order.
  /// Empty without the option. Takes under a second for a run of minutes (3191 states: 0.6 s);
  /// leaves the window as it is. Throws what GTSAM throws for a system it cannot solve.
  std::vector<SmoothedState> smooth_whole_run(int max_iterations = 30) const;

 private:
  bool initialise(double t, const EgoVelocity& ego);
  gtsam::Vector3 gyro_at(double t) const;
  /// The IMU signal over [t0, t1] as pieces between samples: f(accel, gyro, dt) with the piece's
  /// mean under imu_interpolation. After the last sample its value is held.
  template <class F>
  void for_each_imu_piece(double t0, double t1, F&& f) const;
  /// The IMU over [t0, t1] into pim, and into also (the batch's, other noise) in the same walk.
  void preintegrate(double t0, double t1, gtsam::PreintegratedCombinedMeasurements& pim,
                    gtsam::PreintegratedCombinedMeasurements* also = nullptr) const;
  void add_radar_factor(std::uint64_t k, double t, const EgoVelocity& ego);
  void add_zero_rate_factor(std::uint64_t k, double t0, double t1, const EgoVelocity& ego);
  void marginalise_oldest();
  FrontendState state(std::uint64_t k, double t_radar, bool radar_used);

  FrontendOptions options_;
  boost::shared_ptr<gtsam::PreintegrationCombinedParams> params_;        // the window's
  boost::shared_ptr<gtsam::PreintegrationCombinedParams> whole_params_;  // the whole-run batch's
  std::deque<ImuSample> imu_;
  std::deque<std::pair<std::uint64_t, double>> window_;  // state index, IMU-clock time
  gtsam::NonlinearFactorGraph graph_;
  gtsam::Values values_;
  // whole_run_smoother: every factor added (never the marginals), the states that left the window
  // at their estimate then, and each state's radar time.
  gtsam::NonlinearFactorGraph whole_graph_;
  gtsam::Values whole_values_;
  std::vector<std::pair<std::uint64_t, double>> whole_times_;
  /// graph_.add (at_first_estimates), and whole_graph_ with the option (as it is).
  void add_factor(const gtsam::NonlinearFactor::shared_ptr& factor);
  /// first_estimate_jacobians: the variables the newest marginal lies on, at its linearisation
  /// point (empty without the option).
  gtsam::Values first_estimates_;
  /// factor as a FirstEstimateFactor if it reaches first_estimates_, else itself.
  gtsam::NonlinearFactor::shared_ptr at_first_estimates(const gtsam::NonlinearFactor::shared_ptr& factor) const;
  /// The IMU factor from state prev to state k over [t0, t1]: into the window with params_, and
  /// with the option into the batch with whole_params_. Returns the window's preintegration.
  gtsam::PreintegratedCombinedMeasurements add_imu_factor(std::uint64_t prev, std::uint64_t k, double t0, double t1,
                                                          const gtsam::imuBias::ConstantBias& bias);
  std::uint64_t next_ = 0;
  std::uint64_t imu_ignored_ = 0;
  std::uint64_t frames_without_radar_ = 0;
  std::uint64_t zero_rate_updates_ = 0;
  struct StillInterval {
    std::uint64_t k = 0;  // the state that ends the interval
    gtsam::Vector3 mean = gtsam::Vector3::Zero();
    double dt = 0;
    bool candidate = false;
  };
  std::deque<StillInterval> still_;  // the last 2 still_neighbours + 1 intervals
  // continuous_odometry: published = offset_ * window estimate, the offset renewed at each zero-rate
  // update; the last published state.
  gtsam::Pose3 offset_;
  std::uint64_t offset_zero_rate_updates_ = 0;
  gtsam::Pose3 published_;
  std::optional<std::uint64_t> published_k_;
  double published_t_ = 0;                                         // radar clock
  gtsam::Vector3 published_velocity_ = gtsam::Vector3::Zero();     // position_from_velocity
};

}  // namespace rsrio::rio
