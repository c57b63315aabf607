#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include "rsrio/splat/pose.hpp"
#include "splat_test_support.hpp"

using namespace rsrio::splat;
using namespace rsrio::splat::test;

namespace {

// A planar pose with x, y in +-xy, yaw in +-3 rad, z in +-0.2 m, roll and pitch in +-tilt.
PlanarPose random_planar_pose(std::mt19937_64& rng, double xy, double tilt) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PlanarPose p;
  p.x = xy * u(rng);
  p.y = xy * u(rng);
  p.yaw = 3 * u(rng);
  p.z = 0.2 * u(rng);
  p.roll = tilt * u(rng);
  p.pitch = tilt * u(rng);
  return p;
}

}  // namespace

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

TEST_CASE("left_increment_jacobian has orthonormal columns: planar gradients pass through J g unchanged",
          "[splat][pose]") {
  // Backend::odometry_prior adds J g to the left-increment gradient of a pose; planar_gradient
  // then gives J^T J g, which must be g (3-DoF), and 6-DoF poses see the planar prior through J.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    const PlanarPose p = random_planar_pose(rng, 3.0, 0.1);
    const Eigen::Matrix<double, 6, 3> j = left_increment_jacobian(p);
    CHECK((j.transpose() * j - Eigen::Matrix3d::Identity()).norm() < 1e-12);
    const Eigen::Vector3d g(u(rng), u(rng), u(rng));
    CHECK((planar_gradient(p, j * g) - g).norm() < 1e-12);
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

TEST_CASE("Planar yaw prior: zero at the frontend's heading, gradient matches finite differences, wraps",
          "[splat][pose]") {
  PlanarPose p;
  p.x = 1;
  p.y = 2;
  p.yaw = 0.3;
  CHECK(planar_yaw_prior(p, 0.3, 0.01, nullptr) == 0.0);
  for (const double yaw : {0.31, -0.5, 3.1}) {
    p.yaw = yaw;
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    const double odom = yaw == 3.1 ? -3.1 : 0.3;  // across +-pi: the short way round
    const double loss = planar_yaw_prior(p, odom, 0.05, &g);
    CHECK(loss > 0);
    CHECK(g.x() == 0.0);
    CHECK(g.y() == 0.0);
    auto f = [&](double v) {
      PlanarPose q = p;
      q.yaw = v;
      return planar_yaw_prior(q, odom, 0.05, nullptr);
    };
    CHECK(relative_error({g.z()}, {central_difference(f, yaw, 1e-6)}) < 1e-3);
  }
  p.yaw = 3.1;
  CHECK_THAT(planar_yaw_prior(p, -3.1, 1.0, nullptr), Catch::Matchers::WithinRel(0.5 * std::pow(2 * std::numbers::pi - 6.2, 2), 1e-9));
}

TEST_CASE("Planar relative prior: zero at the frontend's motion, gradients match finite differences (isotropic and "
          "split along and across the motion)",
          "[splat][pose]") {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto random_planar = [&] { return random_planar_pose(rng, 5.0, 0.05); };
  for (int trial = 0; trial < 40; ++trial) {
    const double across = trial % 2 == 0 ? 0.0 : 0.002;  // sigma_across_m: off, then 5 x tighter
    INFO("trial " << trial << ", sigma_across_m " << across);
    const PlanarPose a_odom = random_planar(), b_odom = random_planar();
    // The same relative motion seen from another (rotated, shifted) map frame costs nothing.
    PlanarPose a = a_odom, b = b_odom;
    const double turn = u(rng), c = std::cos(turn), s = std::sin(turn);
    for (PlanarPose* p : {&a, &b}) {
      const double x = p->x, y = p->y;
      p->x = c * x - s * y + 1.0;
      p->y = s * x + c * y - 2.0;
      p->yaw += turn;
    }
    CHECK(planar_relative_prior(a, b, a_odom, b_odom, 0.01, 0.003, nullptr, nullptr, across) < 1e-18);
    // Disturbed: positive, and the analytic gradients of both poses match central differences.
    a.x += 0.05 * u(rng);
    a.yaw += 0.02 * u(rng);
    b.y += 0.05 * u(rng);
    b.yaw += 0.02 * u(rng);
    Eigen::Vector3d ga = Eigen::Vector3d::Zero(), gb = Eigen::Vector3d::Zero();
    const double loss = planar_relative_prior(a, b, a_odom, b_odom, 0.01, 0.003, &ga, &gb, across);
    CHECK(loss > 0);
    std::vector<double> analytic, numeric;
    for (int which = 0; which < 2; ++which) {
      for (int k = 0; k < 3; ++k) {
        auto f = [&](double value) {
          PlanarPose pa = a, pb = b;
          PlanarPose& p = which == 0 ? pa : pb;
          (k == 0 ? p.x : k == 1 ? p.y : p.yaw) = value;
          return planar_relative_prior(pa, pb, a_odom, b_odom, 0.01, 0.003, nullptr, nullptr, across);
        };
        const PlanarPose& p = which == 0 ? a : b;
        numeric.push_back(central_difference(f, k == 0 ? p.x : k == 1 ? p.y : p.yaw, 1e-6));
        analytic.push_back((which == 0 ? ga : gb)[k]);
      }
    }
    CHECK(relative_error(analytic, numeric) < 1e-3);
  }
  // A yaw difference across +-pi is the short way round.
  PlanarPose a, b, a_odom, b_odom;
  a.yaw = 3.1;
  b.yaw = -3.1;
  a_odom.yaw = b_odom.yaw = 0.0;
  CHECK_THAT(planar_relative_prior(a, b, a_odom, b_odom, 1.0, 1.0, nullptr, nullptr),
             Catch::Matchers::WithinRel(0.5 * std::pow(2 * std::numbers::pi - 6.2, 2), 1e-9));
}

TEST_CASE("Planar relative prior: sigma_across_m weighs the error across the frontend's motion, not along it",
          "[splat][pose]") {
  using Catch::Matchers::WithinRel;
  // The frontend moved 0.4 m straight ahead at 30 deg of heading; the optimised b lands 1 cm
  // off, once along that motion and once across it.
  PlanarPose a_odom, b_odom;
  a_odom.yaw = b_odom.yaw = 30.0 * std::numbers::pi / 180.0;
  b_odom.x = 0.4 * std::cos(a_odom.yaw);
  b_odom.y = 0.4 * std::sin(a_odom.yaw);
  const PlanarPose a = a_odom;
  PlanarPose along = b_odom, across = b_odom;
  along.x += 0.01 * std::cos(a_odom.yaw);
  along.y += 0.01 * std::sin(a_odom.yaw);
  across.x -= 0.01 * std::sin(a_odom.yaw);
  across.y += 0.01 * std::cos(a_odom.yaw);
  const double iso = 0.5 * 0.01 * 0.01 / (0.2 * 0.2);
  CHECK_THAT(planar_relative_prior(a, along, a_odom, b_odom, 0.2, 0.01, nullptr, nullptr, 0.005), WithinRel(iso, 1e-9));
  CHECK_THAT(planar_relative_prior(a, across, a_odom, b_odom, 0.2, 0.01, nullptr, nullptr, 0.005),
             WithinRel(0.5 * 0.01 * 0.01 / (0.005 * 0.005), 1e-9));
  CHECK_THAT(planar_relative_prior(a, across, a_odom, b_odom, 0.2, 0.01, nullptr, nullptr, 0.0), WithinRel(iso, 1e-9));
  // A keyframe turned against the way it moved (its heading off, not its position): across the
  // motion that costs (0.4 m x the turn)^2 / sigma_across^2, and the pull on its yaw grows with it.
  PlanarPose turned_a = a;
  turned_a.yaw += 0.01;
  Eigen::Vector3d g_iso = Eigen::Vector3d::Zero(), g_split = Eigen::Vector3d::Zero();
  planar_relative_prior(turned_a, b_odom, a_odom, b_odom, 0.2, 1.0, &g_iso, nullptr, 0.0);
  planar_relative_prior(turned_a, b_odom, a_odom, b_odom, 0.2, 1.0, &g_split, nullptr, 0.005);
  CHECK(g_iso.z() > 0);
  CHECK(g_split.z() > 1000 * g_iso.z());  // (0.2 / 0.005)^2 = 1600 times, less the rotation term
  // A turn on the spot (a displacement under kAcrossMinDisplacementM) has no direction: isotropic.
  PlanarPose spot_b = a_odom, spot_moved = a_odom;
  spot_b.yaw += 1.0;
  spot_moved.yaw += 1.0;
  spot_moved.y += 0.01;
  CHECK_THAT(planar_relative_prior(a, spot_moved, a_odom, spot_b, 0.2, 0.01, nullptr, nullptr, 0.005),
             WithinRel(iso, 1e-9));
  CHECK_THROWS_AS(planar_relative_prior(a, along, a_odom, b_odom, 0.2, 0.01, nullptr, nullptr, -0.001),
                  std::invalid_argument);
}

TEST_CASE("Vertical prior: zero at the reference tilt and height, blind to yaw and x, y, gradient matches finite "
          "differences",
          "[splat][pose]") {
  std::mt19937_64 rng(17);
  const double sigma_tilt = 0.5 * std::numbers::pi / 180, sigma_z = 0.05;
  double worst = 0;
  for (int trial = 0; trial < 6; ++trial) {
    const PlanarPose reference = random_planar_pose(rng, 5.0, 0.05);
    const Eigen::Vector3d up = reference.radar_T_world().linear().col(2);
    // At the reference, and anywhere else in x, y, yaw: no loss, no gradient.
    PlanarPose moved = reference;
    moved.x += 1.5;
    moved.y -= 0.7;
    moved.yaw += 2.0;
    Vector6d g0 = Vector6d::Zero();
    CHECK(vertical_prior(moved.radar_T_world(), up, reference.z, sigma_tilt, sigma_z, &g0) < 1e-20);
    CHECK(g0.norm() < 1e-9);
    // Tilted by a few tenths of a degree and off the floor by centimetres.
    PlanarPose off = random_planar_pose(rng, 5.0, 0.05);
    off.roll = reference.roll + 0.01;
    off.pitch = reference.pitch - 0.007;
    off.z = reference.z + 0.03;
    const Eigen::Isometry3d t = off.radar_T_world();
    Vector6d g = Vector6d::Zero();
    const double loss = vertical_prior(t, up, reference.z, sigma_tilt, sigma_z, &g);
    // 0.5 (0.03 / 0.05)^2 from the height and about 0.5 (0.0122 / 0.0087)^2 from the tilt.
    CHECK(loss > 0.5 * std::pow(0.03 / sigma_z, 2));
    Vector6d numeric;
    for (int c = 0; c < 6; ++c) {
      const double h = 1e-7;
      Vector6d d = Vector6d::Zero();
      d[c] = h;
      numeric[c] = (vertical_prior(se3_exp(d) * t, up, reference.z, sigma_tilt, sigma_z, nullptr) -
                    vertical_prior(se3_exp(-d) * t, up, reference.z, sigma_tilt, sigma_z, nullptr)) / (2 * h);
    }
    worst = std::max(worst, relative_error(to_vector(g), to_vector(numeric)));
  }
  std::printf("vertical prior gradcheck: %.2e\n", worst);
  CHECK(worst < 1e-3);
  CHECK_THROWS(vertical_prior(Eigen::Isometry3d::Identity(), Eigen::Vector3d::UnitZ(), 0, 0, 1, nullptr));
  CHECK_THROWS(vertical_prior(Eigen::Isometry3d::Identity(), Eigen::Vector3d::UnitZ(), 0, 1, 0, nullptr));
}

TEST_CASE("extrapolate_planar continues a constant turn exactly over one interval, and b at t_b", "[splat][pose]") {
  // A rig on a circle of radius 3 m at 0.5 m/s, turning left from heading 2.9 rad (it crosses
  // +-pi), its z, roll and pitch held.
  const double radius = 3.0, speed = 0.5, rate = speed / radius, heading0 = 2.9;
  auto rig = [&](double t) {
    const double a = rate * t, c = std::cos(heading0), s = std::sin(heading0);
    const double forward = radius * std::sin(a), left = radius * (1.0 - std::cos(a));
    PlanarPose p;
    p.x = 1.0 + c * forward - s * left;
    p.y = -2.0 + s * forward + c * left;
    p.yaw = std::remainder(heading0 + a, 2 * std::numbers::pi);
    p.z = 0.7;
    p.roll = 0.01;
    p.pitch = -0.02;
    return p;
  };
  const double dt = 0.4;
  for (const double t0 : {0.0, 4.0, 9.5}) {
    const PlanarPose a = rig(t0), b = rig(t0 + dt), truth = rig(t0 + 2 * dt);
    const PlanarPose next = extrapolate_planar(a, t0, b, t0 + dt, t0 + 2 * dt);
    CHECK_THAT(next.x, Catch::Matchers::WithinAbs(truth.x, 1e-12));
    CHECK_THAT(next.y, Catch::Matchers::WithinAbs(truth.y, 1e-12));
    CHECK_THAT(std::remainder(next.yaw - truth.yaw, 2 * std::numbers::pi), Catch::Matchers::WithinAbs(0.0, 1e-12));
    CHECK(next.z == b.z);
    CHECK(next.roll == b.roll);
    CHECK(next.pitch == b.pitch);
    // At t_b it is b itself; half an interval on, the heading exactly and the position to within
    // the chord's turn (half a step of speed dt / 2, off in direction by a quarter of the turn).
    const PlanarPose same = extrapolate_planar(a, t0, b, t0 + dt, t0 + dt);
    CHECK_THAT(same.x, Catch::Matchers::WithinAbs(b.x, 1e-12));
    CHECK_THAT(same.y, Catch::Matchers::WithinAbs(b.y, 1e-12));
    const PlanarPose half = extrapolate_planar(a, t0, b, t0 + dt, t0 + 1.5 * dt), half_truth = rig(t0 + 1.5 * dt);
    CHECK_THAT(std::remainder(half.yaw - half_truth.yaw, 2 * std::numbers::pi), Catch::Matchers::WithinAbs(0.0, 1e-12));
    CHECK(std::hypot(half.x - half_truth.x, half.y - half_truth.y) < 0.5 * speed * dt * 0.25 * rate * dt * 1.1);
  }
  CHECK_THROWS_AS(extrapolate_planar(PlanarPose{}, 1.0, PlanarPose{}, 1.0, 2.0), std::invalid_argument);
}
