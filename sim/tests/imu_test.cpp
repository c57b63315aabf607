// The IMU model against physics (gravity at rest, centripetal force on a circle) and against its
// own noise specification (white-noise level and bias random walk, discretised correctly).
#include <cmath>
#include <numbers>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/sim/imu_simulator.hpp"
#include "rsrio/sim/motion.hpp"

using namespace rsrio::sim;

namespace {

ImuOptions noiseless() {
  ImuOptions o;
  o.gyro_noise_density = o.accel_noise_density = 0;
  o.gyro_bias_random_walk = o.accel_bias_random_walk = 0;
  o.gyro_bias_sigma = o.accel_bias_sigma = 0;
  return o;
}

struct Stats {
  Eigen::Vector3d mean_gyro = Eigen::Vector3d::Zero(), mean_accel = Eigen::Vector3d::Zero();
  Eigen::Vector3d var_gyro = Eigen::Vector3d::Zero(), var_accel = Eigen::Vector3d::Zero();
};

Stats collect(ImuSimulator& imu, int n) {
  std::vector<ImuSample> s;
  for (int i = 0; i < n; ++i) s.push_back(imu.next());
  Stats st;
  for (const auto& x : s) st.mean_gyro += x.angular_velocity / n, st.mean_accel += x.linear_acceleration / n;
  for (const auto& x : s) {
    st.var_gyro += (x.angular_velocity - st.mean_gyro).cwiseAbs2() / (n - 1);
    st.var_accel += (x.linear_acceleration - st.mean_accel).cwiseAbs2() / (n - 1);
  }
  return st;
}

}  // namespace

TEST_CASE("sim: an IMU at rest reads +g up and no rotation, within its noise", "[imu]") {
  const StaticMotion still(Eigen::Vector3d(0, 0, 1), Eigen::Matrix3d::Identity());
  ImuOptions o;  // BMI055-class noise, no biases (so the mean is the truth)
  o.gyro_bias_sigma = o.accel_bias_sigma = 0;
  o.gyro_bias_random_walk = o.accel_bias_random_walk = 0;
  ImuSimulator imu(o, still, 42);
  const int n = 8000;
  const Stats st = collect(imu, n);
  const double sg = imu.gyro_sigma(), sa = imu.accel_sigma();
  // Per-sample white noise = density * sqrt(rate).
  CHECK(std::abs(sg - o.gyro_noise_density * std::sqrt(o.rate_hz)) < 1e-15);
  for (int i = 0; i < 3; ++i) {
    CHECK(std::abs(st.mean_gyro[i]) < 5 * sg / std::sqrt(n));
    CHECK(std::abs(std::sqrt(st.var_gyro[i]) / sg - 1) < 0.05);
    CHECK(std::abs(std::sqrt(st.var_accel[i]) / sa - 1) < 0.05);
  }
  CHECK(std::abs(st.mean_accel.x()) < 5 * sa / std::sqrt(n));
  CHECK(std::abs(st.mean_accel.y()) < 5 * sa / std::sqrt(n));
  CHECK(std::abs(st.mean_accel.z() - o.gravity_mps2) < 5 * sa / std::sqrt(n));
}

TEST_CASE("sim: a tilted IMU at rest sees gravity in its own axes", "[imu]") {
  const Eigen::Matrix3d r = rotation_from_rpy(0.3, -0.2, 1.0);
  const StaticMotion still(Eigen::Vector3d(0, 0, 1), r);
  ImuSimulator imu(noiseless(), still, 1);
  const ImuSample s = imu.next();
  CHECK((s.linear_acceleration - r.transpose() * Eigen::Vector3d(0, 0, 9.81)).norm() < 1e-12);
  CHECK(s.angular_velocity.norm() == 0.0);
}

TEST_CASE("sim: an IMU on a circle feels the centripetal force", "[imu]") {
  const double radius = 2.0, rate = 0.5;
  const CircularMotion circle(Eigen::Vector3d(0, 0, 1), radius, rate, 60);
  ImuSimulator exact(noiseless(), circle, 1);
  for (int i = 0; i < 50; ++i) {
    const ImuSample s = exact.next();
    // Body y points at the centre: specific force (0, r w^2, g), yaw rate w.
    CHECK((s.linear_acceleration - Eigen::Vector3d(0, radius * rate * rate, 9.81)).norm() < 1e-9);
    CHECK((s.angular_velocity - Eigen::Vector3d(0, 0, rate)).norm() < 1e-12);
  }
  ImuOptions o;
  o.gyro_bias_sigma = o.accel_bias_sigma = 0;
  o.gyro_bias_random_walk = o.accel_bias_random_walk = 0;
  ImuSimulator noisy(o, circle, 2);
  const Stats st = collect(noisy, 4000);
  CHECK(std::abs(st.mean_accel.y() - radius * rate * rate) < 5 * noisy.accel_sigma() / std::sqrt(4000.0));
  CHECK(std::abs(st.mean_gyro.z() - rate) < 5 * noisy.gyro_sigma() / std::sqrt(4000.0));
}

TEST_CASE("sim: IMU biases walk with the configured density", "[imu]") {
  const StaticMotion still(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  ImuOptions o = noiseless();
  o.gyro_bias_random_walk = 2e-5;
  o.accel_bias_random_walk = 3e-4;
  const int steps = 2000, runs = 300;
  // After n steps of dt the walk's variance is q^2 n dt, whatever the rate.
  double var_g = 0, var_a = 0;
  for (int seed = 0; seed < runs; ++seed) {
    ImuSimulator imu(o, still, static_cast<std::uint64_t>(seed));
    ImuSample s;
    for (int i = 0; i <= steps; ++i) s = imu.next();
    var_g += s.gyro_bias.squaredNorm() / (3.0 * runs);
    var_a += s.accel_bias.squaredNorm() / (3.0 * runs);
    CHECK((s.angular_velocity - s.gyro_bias).norm() < 1e-15);  // no white noise configured
  }
  const double t = steps / o.rate_hz;
  CHECK(std::abs(var_g / (o.gyro_bias_random_walk * o.gyro_bias_random_walk * t) - 1) < 0.12);
  CHECK(std::abs(var_a / (o.accel_bias_random_walk * o.accel_bias_random_walk * t) - 1) < 0.12);
}

TEST_CASE("sim: IMU samples are deterministic for a seed and on a fixed clock", "[imu]") {
  const CircularMotion circle(Eigen::Vector3d(0, 0, 1), 1.0, 0.3, 60);
  ImuSimulator a(ImuOptions{}, circle, 5), b(ImuOptions{}, circle, 5), c(ImuOptions{}, circle, 6);
  bool differs = false;
  for (int i = 0; i < 100; ++i) {
    const ImuSample x = a.next(), y = b.next(), z = c.next();
    CHECK(x.time == i / 200.0);
    CHECK(x.linear_acceleration == y.linear_acceleration);
    CHECK(x.angular_velocity == y.angular_velocity);
    differs = differs || x.linear_acceleration != z.linear_acceleration;
  }
  CHECK(differs);
}
