// RadarVelocityFactor: the prediction against kinematics worked out independently, and every
// analytic Jacobian block against central finite differences on random states.
#include "rsrio/rio/radar_velocity_factor.hpp"

#include <random>

#include <catch2/catch_test_macros.hpp>
#include <gtsam/inference/Symbol.h>

using gtsam::symbol_shorthand::B;
using gtsam::symbol_shorthand::V;
using gtsam::symbol_shorthand::X;
using rsrio::rio::RadarVelocityFactor;

namespace {

gtsam::Vector3 random_vec(std::mt19937& rng, double s) {
  std::normal_distribution<double> n(0, s);
  return {n(rng), n(rng), n(rng)};
}

// Central differences of f over a manifold value through its retract (GTSAM's right perturbation).
template <typename T, typename F>
gtsam::Matrix numerical(const T& x, F f, int dim, double h = 1e-6) {
  gtsam::Matrix J(3, dim);
  for (int i = 0; i < dim; ++i) {
    gtsam::Vector d = gtsam::Vector::Zero(dim);
    d(i) = h;
    J.col(i) = (f(gtsam::traits<T>::Retract(x, d)) - f(gtsam::traits<T>::Retract(x, -d))) / (2 * h);
  }
  return J;
}

}  // namespace

TEST_CASE("prediction: radar velocity from body velocity, rotation and lever arm", "[radar_factor]") {
  // Body moving forward (x) at 1 m/s in the world, yawed 90 deg, turning at 0.5 rad/s about z;
  // radar 0.2 m ahead of the IMU, looking forward: it sees 1 m/s forward in the world direction
  // the body faces, plus the lever arm omega x l = 0.5 z x 0.2 x = 0.1 y.
  const gtsam::Pose3 T(gtsam::Rot3::Yaw(M_PI / 2), gtsam::Point3(3, 4, 0));
  const gtsam::Vector3 v_W(0, 1, 0);  // forward for a body yawed 90 deg
  const gtsam::Pose3 body_T_radar(gtsam::Rot3(), gtsam::Point3(0.2, 0, 0));
  RadarVelocityFactor f(X(0), V(0), B(0), gtsam::Vector3::Zero(), gtsam::Vector3(0, 0, 0.5), body_T_radar,
                        gtsam::noiseModel::Isotropic::Sigma(3, 0.1));
  const gtsam::Vector3 h = f.predict(T, v_W, gtsam::imuBias::ConstantBias());
  CHECK((h - gtsam::Vector3(1.0, 0.1, 0.0)).norm() < 1e-12);
  // A gyro bias of 0.5 rad/s about z cancels the measured turn: no lever-arm term left.
  const gtsam::Vector3 h_b = f.predict(T, v_W, gtsam::imuBias::ConstantBias(gtsam::Vector3::Zero(), gtsam::Vector3(0, 0, 0.5)));
  CHECK((h_b - gtsam::Vector3(1.0, 0.0, 0.0)).norm() < 1e-12);
}

TEST_CASE("analytic Jacobians match central finite differences on random states", "[radar_factor]") {
  std::mt19937 rng(2024);
  for (int trial = 0; trial < 50; ++trial) {
    const gtsam::Pose3 T(gtsam::Rot3::Expmap(random_vec(rng, 1.0)), random_vec(rng, 5.0));
    const gtsam::Vector3 v_W = random_vec(rng, 1.5);
    const gtsam::imuBias::ConstantBias b(random_vec(rng, 0.1), random_vec(rng, 0.05));
    const gtsam::Pose3 body_T_radar(gtsam::Rot3::Expmap(random_vec(rng, 0.5)), random_vec(rng, 0.3));
    RadarVelocityFactor f(X(0), V(0), B(0), random_vec(rng, 1.0), random_vec(rng, 0.8), body_T_radar,
                          gtsam::noiseModel::Isotropic::Sigma(3, 0.1));
    gtsam::Matrix Hp, Hv, Hb;
    f.evaluateError(T, v_W, b, Hp, Hv, Hb);
    const auto err = [&](const gtsam::Pose3& t, const gtsam::Vector3& v, const gtsam::imuBias::ConstantBias& bb) {
      return gtsam::Vector3(f.evaluateError(t, v, bb));
    };
    const gtsam::Matrix Np = numerical(T, [&](const gtsam::Pose3& t) { return err(t, v_W, b); }, 6);
    const gtsam::Matrix Nv = numerical(v_W, [&](const gtsam::Vector3& v) { return err(T, v, b); }, 3);
    const gtsam::Matrix Nb = numerical(b, [&](const gtsam::imuBias::ConstantBias& bb) { return err(T, v_W, bb); }, 6);
    INFO("trial " << trial);
    CHECK((Hp - Np).norm() <= 1e-6 * std::max(1.0, Np.norm()));
    CHECK((Hv - Nv).norm() <= 1e-6 * std::max(1.0, Nv.norm()));
    CHECK((Hb - Nb).norm() <= 1e-6 * std::max(1.0, Nb.norm()));
  }
}

TEST_CASE("clone keeps the measurement (GTSAM 4.2's default clone throws)", "[radar_factor]") {
  RadarVelocityFactor f(X(1), V(1), B(1), gtsam::Vector3(1, 2, 3), gtsam::Vector3::Zero(), gtsam::Pose3(),
                        gtsam::noiseModel::Isotropic::Sigma(3, 0.1));
  const auto c = boost::dynamic_pointer_cast<RadarVelocityFactor>(f.clone());
  REQUIRE(c);
  CHECK(c->measured() == gtsam::Vector3(1, 2, 3));
  CHECK(c->keys() == f.keys());
}
