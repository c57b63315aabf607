// A consumer MEMS IMU (scenario section `imu`): specific force and angular rate in the IMU frame
// from the exact motion, plus white noise and random-walk biases.
//
// Model (continuous-time densities, discretised at the sample rate f = 1/dt):
//   gyro  = omega_imu + b_g + n_g,   n_g ~ N(0, (gyro_noise_density^2 f) I)
//   accel = R^T (a - g_world) + b_a + n_a,   g_world = (0, 0, -gravity): at rest accel = (0, 0, +g)
//   b_{k+1} = b_k + N(0, (bias_random_walk^2 dt) I),  b_0 ~ N(0, bias_sigma^2 I)
// Defaults are the Bosch BMI055 of the paper's RealSense D435i: gyro 0.014 deg/s/sqrt(Hz),
// accelerometer 150 ug/sqrt(Hz) (datasheet noise densities); random walks of the size Kalibr /
// Allan-variance calibrations of D435i units report.
#pragma once

#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "rsrio/sim/motion.hpp"

namespace rsrio::sim {

struct ImuOptions {
  double rate_hz = 200.0;
  double gyro_noise_density = 2.4e-4;      // rad/s/sqrt(Hz)
  double accel_noise_density = 1.5e-3;     // m/s^2/sqrt(Hz)
  double gyro_bias_random_walk = 2.0e-5;   // rad/s^2/sqrt(Hz)
  double accel_bias_random_walk = 3.0e-4;  // m/s^3/sqrt(Hz)
  double gyro_bias_sigma = 3.0e-3;         // rad/s, initial bias (per axis, drawn once)
  double accel_bias_sigma = 3.0e-2;        // m/s^2
  double gravity_mps2 = 9.81;
};

struct ImuSample {
  double time = 0;                                            // true time of the sample, s
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // measured, IMU frame, rad/s
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();  // measured specific force, m/s^2
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();        // the true biases in this sample
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
};

/// Makes the samples of one IMU in time order: sample j at time start + j / rate.
class ImuSimulator {
 public:
  /// `imu_motion` is the motion of the IMU frame itself; it must outlive the simulator.
  ImuSimulator(const ImuOptions& options, const Motion& imu_motion, std::uint64_t seed, double start_s = 0.0);
  ~ImuSimulator();

  /// The next sample. Deterministic for the seed.
  ImuSample next();
  /// Time of the sample next() returns.
  double next_time() const;
  const ImuOptions& options() const { return options_; }

  /// White-noise standard deviations per sample (density * sqrt(rate)).
  double gyro_sigma() const;
  double accel_sigma() const;

 private:
  struct Impl;
  ImuOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsrio::sim
