// Rigid-body motion in closed form: the ground truth every simulated measurement is made from.
//
// Frames: the world ("map") is z up with gravity along -z; a body frame is x forward, y left,
// z up (FLU). A RigState holds everything a sensor model needs at one instant, exactly (no
// numerical differentiation anywhere): position, orientation, linear velocity and acceleration
// in the world, angular velocity and angular acceleration in the body's own axes.
//
// SplineTrajectory is the walking path of a person carrying the sensor rig (or of a pedestrian in
// the scene): a uniform cubic B-spline in time whose control points are the waypoint polyline
// resampled at speed x knot interval. A uniform B-spline reproduces straight lines at constant
// speed exactly and rounds corners; it is C2 in position (velocity and acceleration continuous,
// jerk piecewise constant), so the IMU sees no impossible steps. Heading is a B-spline of its
// own through the polyline's segment headings, blended linearly over +-turn_distance_m around
// each corner and turning on the spot during pauses (so it leads the velocity a little in
// corners, as a person looking into a turn does), and walking adds
// a small vertical bob and roll/pitch sway whose amplitude follows the walking speed (zero when
// standing).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rsrio::sim {

/// The exact kinematic state of a frame at one time.
struct RigState {
  double time = 0;                                                   // s (scenario time)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();                // frame origin in the world, m
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();            // p_world = rotation * p_frame + position
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();                // of the origin, world axes, m/s
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();            // of the origin, world axes, m/s^2
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();        // frame axes, rad/s
  Eigen::Vector3d angular_acceleration = Eigen::Vector3d::Zero();    // frame axes, rad/s^2
};

/// A frame rigidly attached to another: its pose expressed in the parent frame.
struct Mount {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // child axes in the parent frame
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   // child origin in the parent frame, m
};

/// The state of a child frame rigidly mounted on `parent`: lever-arm velocity omega x l and
/// acceleration alpha x l + omega x (omega x l) included.
RigState attached(const RigState& parent, const Mount& mount);

/// Rotation from roll, pitch, yaw (rad), applied as R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix3d rotation_from_rpy(double roll, double pitch, double yaw);

/// Anything that moves a frame through the world in closed form.
class Motion {
 public:
  virtual ~Motion() = default;
  /// The exact state at time t (s), for any t. Must be callable from several threads at once.
  virtual RigState state(double t) const = 0;
  /// The nominal length of the motion, s (a trajectory stands still after it).
  virtual double duration() const = 0;
};

/// Stands still forever.
class StaticMotion final : public Motion {
 public:
  StaticMotion(Eigen::Vector3d position, Eigen::Matrix3d rotation);
  RigState state(double t) const override;
  double duration() const override { return 0; }

 private:
  Eigen::Vector3d position_;
  Eigen::Matrix3d rotation_;
};

/// Constant velocity and fixed orientation: position(t) = start + velocity * t.
class LinearMotion final : public Motion {
 public:
  LinearMotion(Eigen::Vector3d start, Eigen::Vector3d velocity, Eigen::Matrix3d rotation, double duration_s);
  RigState state(double t) const override;
  double duration() const override { return duration_; }

 private:
  Eigen::Vector3d start_, velocity_;
  Eigen::Matrix3d rotation_;
  double duration_;
};

/// Uniform circular motion in the horizontal plane, counter-clockwise seen from above, the body x
/// axis along the direction of travel (y then points at the centre), at height `center.z()`.
class CircularMotion final : public Motion {
 public:
  CircularMotion(Eigen::Vector3d center, double radius_m, double angular_rate_rad_s, double duration_s);
  RigState state(double t) const override;
  double duration() const override { return duration_; }

 private:
  Eigen::Vector3d center_;
  double radius_, rate_, duration_;
};

/// The walking path (scenario section `trajectory`, documented in scenarios/README.md).
struct TrajectoryOptions {
  std::vector<Eigen::Vector2d> waypoints;   // m, at least two distinct points
  double speed_mps = 0.6;                   // walking speed on every segment...
  std::vector<double> segment_speeds_mps;   // ...unless given per segment (waypoints - 1 entries)
  std::vector<double> pauses_s;             // standing time at each waypoint (empty: none)
  double knot_interval_s = 0.6;             // B-spline knot spacing: larger turns corners wider and slower
  double turn_distance_m = 0.6;             // the heading turns over +- this arc length around a corner
  double still_start_s = 3.0;               // standing still before walking (IMU initialisation)
  double still_end_s = 2.0;                 // standing still at the end
  double height_m = 1.0;                    // height of the frame origin above the floor
  double bob_amplitude_m = 0.0;             // vertical bob at the step frequency while walking
  double roll_amplitude_deg = 0.0;          // sway at half the step frequency (one gait cycle)
  double pitch_amplitude_deg = 0.0;         // nod at the step frequency
  double step_frequency_hz = 1.8;
};

class SplineTrajectory final : public Motion {
 public:
  /// Throws std::invalid_argument for an unusable path (fewer than two distinct points, a
  /// non-positive speed or knot interval, list sizes that do not match the waypoints).
  explicit SplineTrajectory(const TrajectoryOptions& options);

  RigState state(double t) const override;
  double duration() const override { return duration_; }

  /// Path length in the horizontal plane (numerical quadrature of the exact speed), m.
  double length() const;
  /// Horizontal speed |v_xy| at t, m/s.
  double speed(double t) const;

  const TrajectoryOptions& options() const { return options_; }
  const std::vector<Eigen::Vector2d>& control_points() const { return control_; }

 private:
  struct Planar {
    Eigen::Vector2d p, v, a, j;
    double yaw, yaw_rate, yaw_acc;
  };
  Planar planar(double t) const;

  TrajectoryOptions options_;
  std::vector<Eigen::Vector2d> control_;
  std::vector<double> yaw_control_;
  double dt_ = 0;
  double duration_ = 0;
  double envelope_q0_ = 0;  // (speed)^2 at which the walking sway reaches half amplitude
};

}  // namespace rsrio::sim
