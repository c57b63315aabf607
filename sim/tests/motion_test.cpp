// Closed-form motion: every derivative the simulator uses must agree with numerical
// differentiation of the positions and orientations, and the walking trajectory must be the
// length and speed it was asked for.
#include <cmath>
#include <numbers>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/sim/motion.hpp"

using namespace rsrio::sim;

namespace {

Eigen::Vector3d vee_of_skew_part(const Eigen::Matrix3d& m) {
  const Eigen::Matrix3d s = 0.5 * (m - m.transpose());
  return Eigen::Vector3d(s(2, 1), s(0, 2), s(1, 0));
}

// Central differences of a motion at t against its closed-form derivatives.
void check_derivatives(const Motion& motion, double t, double tol_v, double tol_a, double tol_w, double tol_alpha) {
  const double h = 1e-4;
  const RigState s = motion.state(t), a = motion.state(t - h), b = motion.state(t + h);
  INFO("t = " << t);
  CHECK((s.velocity - (b.position - a.position) / (2 * h)).norm() < tol_v);
  CHECK((s.acceleration - (b.velocity - a.velocity) / (2 * h)).norm() < tol_a);
  // omega^ = R^T dR/dt
  const Eigen::Vector3d w = vee_of_skew_part(s.rotation.transpose() * (b.rotation - a.rotation) / (2 * h));
  CHECK((s.angular_velocity - w).norm() < tol_w);
  CHECK((s.angular_acceleration - (b.angular_velocity - a.angular_velocity) / (2 * h)).norm() < tol_alpha);
}

TrajectoryOptions walk() {
  TrajectoryOptions o;
  o.waypoints = {{0, 0}, {6, 0}, {6, 4}, {1, 5}, {-2, 1}};
  o.speed_mps = 0.7;
  o.pauses_s = {0, 0, 2.0, 0, 0};
  o.bob_amplitude_m = 0.015;
  o.roll_amplitude_deg = 1.0;
  o.pitch_amplitude_deg = 0.8;
  return o;
}

}  // namespace

TEST_CASE("sim: a straight walk has the asked length and speed", "[motion]") {
  TrajectoryOptions o;
  o.waypoints = {{1, 2}, {11, 2}};
  o.speed_mps = 0.5;
  o.still_start_s = 3.0;
  o.still_end_s = 2.0;
  const SplineTrajectory t(o);
  CHECK(std::abs(t.length() - 10.0) < 1e-6);
  // Standing still at the start, cruising at exactly 0.5 m/s in the middle, along +x.
  CHECK(t.speed(1.0) < 1e-12);
  const RigState mid = t.state(t.duration() / 2);
  CHECK(std::abs(mid.velocity.x() - 0.5) < 1e-12);
  CHECK(std::abs(mid.position.y() - 2.0) < 1e-12);
  CHECK(std::abs(mid.position.z() - 1.0) < 1e-12);
  // Duration: stands (3 + 2 s) + 10 m at 0.5 m/s + about one knot interval of ramps at each end.
  CHECK(t.duration() > 25.0);
  CHECK(t.duration() < 25.0 + 4 * o.knot_interval_s);
  CHECK((t.state(t.duration()).position - Eigen::Vector3d(11, 2, 1)).norm() < 1e-12);
  CHECK(t.state(t.duration() + 5).velocity.norm() == 0.0);
}

TEST_CASE("sim: walking trajectory derivatives are exact", "[motion]") {
  const SplineTrajectory t(walk());
  REQUIRE(t.duration() > 20);
  // (Jerk and angular jerk jump at knots: central differences of the acceleration are 1e-4 off there.)
  for (double time = 0.05; time < t.duration(); time += 0.37) check_derivatives(t, time, 1e-6, 1e-3, 1e-6, 1e-3);
}

TEST_CASE("sim: the walk turns smoothly and stays on the path", "[motion]") {
  const SplineTrajectory t(walk());
  double max_acc = 0, max_yaw_rate = 0;
  for (double time = 0; time < t.duration(); time += 0.01) {
    const RigState s = t.state(time);
    max_acc = std::max(max_acc, s.acceleration.head<2>().norm());
    max_yaw_rate = std::max(max_yaw_rate, std::abs(s.angular_velocity.z()));
  }
  CHECK(max_acc < 2.0);                               // m/s^2: a walker, not a robot arm
  CHECK(max_yaw_rate < 120 * std::numbers::pi / 180);  // rad/s
  // Corners are rounded, so the path is a little shorter than the polyline, never longer.
  const double polyline = 6 + 4 + std::hypot(5, 1) + std::hypot(3, 4);
  CHECK(t.length() < polyline);
  CHECK(t.length() > 0.97 * polyline);
  // The pause at the third waypoint: standing on it, turning on the spot.
  bool stood_there = false;
  for (double time = 0; time < t.duration(); time += 0.05) {
    const RigState s = t.state(time);
    if ((s.position.head<2>() - Eigen::Vector2d(6, 4)).norm() < 1e-9 && s.velocity.head<2>().norm() < 1e-12)
      stood_there = true;
  }
  CHECK(stood_there);
}

TEST_CASE("sim: a rigidly mounted frame moves with the lever arm", "[motion]") {
  const SplineTrajectory t(walk());
  Mount m;
  m.translation = Eigen::Vector3d(0.1, -0.05, 0.2);
  m.rotation = rotation_from_rpy(0.1, -0.2, 0.3);
  struct Mounted final : Motion {
    const Motion& parent;
    Mount mount;
    Mounted(const Motion& p, Mount mm) : parent(p), mount(mm) {}
    RigState state(double time) const override { return attached(parent.state(time), mount); }
    double duration() const override { return parent.duration(); }
  } mounted(t, m);
  for (double time = 3.3; time < t.duration(); time += 1.13) check_derivatives(mounted, time, 1e-6, 1e-3, 1e-6, 1e-3);
  const RigState p = t.state(7.0), c = mounted.state(7.0);
  CHECK((c.position - (p.position + p.rotation * m.translation)).norm() < 1e-12);
  CHECK((c.rotation - p.rotation * m.rotation).norm() < 1e-12);
}

TEST_CASE("sim: circular and linear motions are exact", "[motion]") {
  const CircularMotion c(Eigen::Vector3d(1, 2, 0.5), 2.0, 0.5, 10);
  for (double time = 0.1; time < 10; time += 0.9) check_derivatives(c, time, 1e-7, 1e-6, 1e-7, 1e-6);
  const RigState s = c.state(1.0);
  // Body x along the direction of travel, y at the centre.
  CHECK((s.rotation.col(0) - s.velocity.normalized()).norm() < 1e-12);
  CHECK((s.rotation.col(1) - (Eigen::Vector3d(1, 2, 0.5) - s.position).normalized()).norm() < 1e-12);
  const LinearMotion l(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.3, 0.1, 0), Eigen::Matrix3d::Identity(), 5);
  check_derivatives(l, 2.0, 1e-9, 1e-9, 1e-12, 1e-12);
}

TEST_CASE("sim: an unusable path is refused", "[motion]") {
  TrajectoryOptions o;
  o.waypoints = {{0, 0}};
  CHECK_THROWS_AS(SplineTrajectory(o), std::invalid_argument);
  o.waypoints = {{0, 0}, {0, 0}, {1, 0}};
  CHECK_THROWS_AS(SplineTrajectory(o), std::invalid_argument);
  o.waypoints = {{0, 0}, {1, 0}};
  o.pauses_s = {1.0};
  CHECK_THROWS_AS(SplineTrajectory(o), std::invalid_argument);
}
