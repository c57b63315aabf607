#include "rsrio/sim/imu_simulator.hpp"

#include <cmath>
#include <stdexcept>

#include "random.hpp"

namespace rsrio::sim {

namespace {
enum Stream : std::uint64_t { kImuStream = 201 };
}

struct ImuSimulator::Impl {
  const Motion& motion;
  detail::Random rng;
  double start = 0, dt = 0;
  std::uint64_t index = 0;
  Eigen::Vector3d gyro_bias, accel_bias;

  Impl(const Motion& m, std::uint64_t seed, double start_s, double rate)
      : motion(m), rng(detail::stream_seed(seed, kImuStream)), start(start_s), dt(1.0 / rate) {}

  // Drawn one by one: the evaluation order of constructor arguments is unspecified.
  Eigen::Vector3d normal3() {
    Eigen::Vector3d v;
    v.x() = rng.normal();
    v.y() = rng.normal();
    v.z() = rng.normal();
    return v;
  }
};

ImuSimulator::ImuSimulator(const ImuOptions& options, const Motion& imu_motion, std::uint64_t seed, double start_s)
    : options_(options) {
  if (!(options.rate_hz > 0)) throw std::invalid_argument("IMU rate must be positive");
  impl_ = std::make_unique<Impl>(imu_motion, seed, start_s, options.rate_hz);
  impl_->gyro_bias = options.gyro_bias_sigma * impl_->normal3();
  impl_->accel_bias = options.accel_bias_sigma * impl_->normal3();
}

ImuSimulator::~ImuSimulator() = default;

double ImuSimulator::gyro_sigma() const { return options_.gyro_noise_density * std::sqrt(options_.rate_hz); }
double ImuSimulator::accel_sigma() const { return options_.accel_noise_density * std::sqrt(options_.rate_hz); }

double ImuSimulator::next_time() const {
  return impl_->start + static_cast<double>(impl_->index) / options_.rate_hz;
}

ImuSample ImuSimulator::next() {
  Impl& d = *impl_;
  const double t = next_time();
  const RigState s = d.motion.state(t);
  const Eigen::Vector3d gravity(0, 0, -options_.gravity_mps2);
  ImuSample out;
  out.time = t;
  out.gyro_bias = d.gyro_bias;
  out.accel_bias = d.accel_bias;
  out.angular_velocity = s.angular_velocity + d.gyro_bias + gyro_sigma() * d.normal3();
  out.linear_acceleration =
      s.rotation.transpose() * (s.acceleration - gravity) + d.accel_bias + accel_sigma() * d.normal3();
  // Biases walk between samples.
  const double sqrt_dt = std::sqrt(d.dt);
  d.gyro_bias += options_.gyro_bias_random_walk * sqrt_dt * d.normal3();
  d.accel_bias += options_.accel_bias_random_walk * sqrt_dt * d.normal3();
  ++d.index;
  return out;
}

}  // namespace rsrio::sim
