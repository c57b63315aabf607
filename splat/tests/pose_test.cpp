#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <cstdio>
#include <random>

#include "rsrio/splat/pose.hpp"
#include "splat_test_support.hpp"

using namespace rsrio::splat;
using namespace rsrio::splat::test;

TEST_CASE("se3_exp is a rigid motion and a left increment moves radar-frame points by rho + omega x p",
          "[splat][pose]") {
  Vector6d d;
  d << 0.1, -0.2, 0.3, 0.02, -0.01, 0.03;
  const Eigen::Isometry3d t = se3_exp(d);
  CHECK((t.linear() * t.linear().transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  CHECK_THAT(t.linear().determinant(), Catch::Matchers::WithinAbs(1.0, 1e-12));
  const Eigen::Vector3d p(3, 1, -0.5);
  Vector6d small = d * 1e-6;
  const Eigen::Vector3d moved = se3_exp(small) * p;
  const Eigen::Vector3d predicted = p + small.head<3>() + small.tail<3>().cross(p);
  CHECK((moved - predicted).norm() < 1e-11);
  CHECK((se3_exp(Vector6d::Zero()).matrix() - Eigen::Matrix4d::Identity()).norm() == 0.0);
}

TEST_CASE("PlanarPose round-trips and its left-increment Jacobian matches finite differences", "[splat][pose]") {
  PlanarPose p;
  p.x = 1.5;
  p.y = -2.0;
  p.yaw = 0.7;
  p.z = 0.3;
  p.roll = 0.05;
  p.pitch = -0.08;
  const PlanarPose back = PlanarPose::from_world_T_radar(p.world_T_radar());
  CHECK_THAT(back.x, Catch::Matchers::WithinAbs(p.x, 1e-12));
  CHECK_THAT(back.yaw, Catch::Matchers::WithinAbs(p.yaw, 1e-12));
  CHECK_THAT(back.roll, Catch::Matchers::WithinAbs(p.roll, 1e-12));
  CHECK_THAT(back.pitch, Catch::Matchers::WithinAbs(p.pitch, 1e-12));
  // A radar-frame point of a fixed world point, as a function of the planar parameters.
  const Eigen::Vector3d world(4, 1, 0.5);
  const Eigen::Matrix<double, 6, 3> j = left_increment_jacobian(p);
  for (int k = 0; k < 3; ++k) {
    const double h = 1e-6;
    PlanarPose a = p, b = p;
    (k == 0 ? a.x : k == 1 ? a.y : a.yaw) += h;
    (k == 0 ? b.x : k == 1 ? b.y : b.yaw) -= h;
    const Eigen::Vector3d numeric = (a.radar_T_world() * world - b.radar_T_world() * world) / (2 * h);
    const Eigen::Vector3d pr = p.radar_T_world() * world;
    const Eigen::Vector3d analytic = j.block<3, 1>(0, k) + j.block<3, 1>(3, k).cross(pr);
    CHECK((numeric - analytic).norm() < 1e-8);
  }
}

TEST_CASE("Radar velocity from two poses: value and Jacobians", "[splat][pose]") {
  std::mt19937_64 rng(3);
  // Moving forward along the radar's x: the velocity is +x in the radar frame.
  PlanarPose a, b;
  a.yaw = b.yaw = 0.6;
  b.x = a.x + 0.5 * std::cos(0.6);
  b.y = a.y + 0.5 * std::sin(0.6);
  const RadarVelocity fwd = radar_velocity_from_poses(b.radar_T_world(), a.radar_T_world(), 0.25);
  CHECK((fwd.velocity - Eigen::Vector3d(2.0, 0, 0)).norm() < 1e-12);

  double worst_current = 0, worst_previous = 0;
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Isometry3d tk = random_pose(rng, 3.0, 1.0), tkm1 = random_pose(rng, 3.0, 1.0);
    const double dt = 0.1;
    const RadarVelocity v = radar_velocity_from_poses(tk, tkm1, dt);
    Eigen::Matrix<double, 3, 6> nk, nkm1;
    for (int c = 0; c < 6; ++c) {
      const double h = 1e-6;
      Vector6d d = Vector6d::Zero();
      d[c] = h;
      nk.col(c) = (radar_velocity_from_poses(se3_exp(d) * tk, tkm1, dt).velocity -
                   radar_velocity_from_poses(se3_exp(-d) * tk, tkm1, dt).velocity) / (2 * h);
      nkm1.col(c) = (radar_velocity_from_poses(tk, se3_exp(d) * tkm1, dt).velocity -
                     radar_velocity_from_poses(tk, se3_exp(-d) * tkm1, dt).velocity) / (2 * h);
    }
    worst_current = std::max(worst_current, (v.d_current - nk).cwiseAbs().maxCoeff() / nk.cwiseAbs().maxCoeff());
    worst_previous = std::max(worst_previous, (v.d_previous - nkm1).cwiseAbs().maxCoeff() / nkm1.cwiseAbs().maxCoeff());
  }
  std::printf("velocity-from-poses gradcheck: d/dT_k %.2e d/dT_k-1 %.2e\n", worst_current, worst_previous);
  CHECK(worst_current < 1e-3);
  CHECK(worst_previous < 1e-3);

  // Planar: chain through left_increment_jacobian.
  PlanarPose p0, p1;
  p0.x = 0.2; p0.y = 0.1; p0.yaw = 0.3;
  p1.x = 0.5; p1.y = 0.3; p1.yaw = 0.35;
  const RadarVelocity v = radar_velocity_from_poses(p1.radar_T_world(), p0.radar_T_world(), 0.1);
  const Eigen::Matrix3d analytic = v.d_current * left_increment_jacobian(p1);
  Eigen::Matrix3d numeric;
  for (int k = 0; k < 3; ++k) {
    const double h = 1e-6;
    PlanarPose plus = p1, minus = p1;
    (k == 0 ? plus.x : k == 1 ? plus.y : plus.yaw) += h;
    (k == 0 ? minus.x : k == 1 ? minus.y : minus.yaw) -= h;
    numeric.col(k) = (radar_velocity_from_poses(plus.radar_T_world(), p0.radar_T_world(), 0.1).velocity -
                      radar_velocity_from_poses(minus.radar_T_world(), p0.radar_T_world(), 0.1).velocity) / (2 * h);
  }
  CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-3 * numeric.cwiseAbs().maxCoeff());
  CHECK_THROWS(radar_velocity_from_poses(p1.radar_T_world(), p0.radar_T_world(), 0.0));
}
