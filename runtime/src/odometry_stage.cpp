#include "rsrio/runtime/odometry_stage.hpp"

#include <cmath>

namespace rsrio {

OdometryStage::OdometryStage(const RadarConfig& radar, const rio::OdometryOptions& options)
    : odometry_(radar, options) {}

void OdometryStage::add_imu(const rio::ImuSample& sample) { odometry_.add_imu(sample); }

bool OdometryStage::add_frame(double t, const AdcCube& cube, PoseOutput& out) {
  ++frames_;
  const rio::FrameInfo& info = odometry_.add_radar_frame(t, cube);
  const rio::EgoVelocity& ego = info.ego;
  if (!ego.ok()) ++ego_rejected_;
  const auto& state = info.state;
  if (!state) return false;
  // The state belongs to the middle of the frame (its Doppler is averaged over the chirps), not to
  // the stamp of its last chirp: publish it with the time it is true at.
  out.stamp_ns -= std::llround((info.t_stamp - info.t) * 1e9);
  last_t_ = info.t;
  last_odom_T_body_ = state->world_T_body;

  const gtsam::Rot3 R = state->world_T_body.rotation();
  const gtsam::Point3 p = state->world_T_body.translation();
  const gtsam::Quaternion q = R.toQuaternion();
  out.position = {p.x(), p.y(), p.z()};
  out.orientation = {q.x(), q.y(), q.z(), q.w()};
  const gtsam::Vector3 v_body = R.unrotate(state->velocity_world);
  out.linear_velocity = {v_body.x(), v_body.y(), v_body.z()};
  // The turn rate at the pose's time (the gyro interpolated there), not the newest sample's.
  const gtsam::Vector3& w = state->angular_velocity_body;
  out.angular_velocity = {w.x(), w.y(), w.z()};
  // GTSAM's pose covariance is on the body-frame tangent [rotation, translation]; ROS wants
  // [x y z, rot x y z] in the header frame: reorder the blocks and rotate them into the world.
  gtsam::Matrix6 ros;
  const gtsam::Matrix3 Rm = R.matrix();
  const gtsam::Matrix6& c = state->pose_covariance;
  ros.block<3, 3>(0, 0) = Rm * c.block<3, 3>(3, 3) * Rm.transpose();
  ros.block<3, 3>(3, 3) = Rm * c.block<3, 3>(0, 0) * Rm.transpose();
  ros.block<3, 3>(0, 3) = Rm * c.block<3, 3>(3, 0) * Rm.transpose();
  ros.block<3, 3>(3, 0) = ros.block<3, 3>(0, 3).transpose();
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) out.pose_covariance[static_cast<std::size_t>(i * 6 + j)] = ros(i, j);
  out.twist_covariance.fill(0.0);
  for (int i = 0; i < 3; ++i) {
    out.twist_covariance[static_cast<std::size_t>(i * 7)] = ego.ok() ? ego.covariance(i, i) : -1.0;
    out.twist_covariance[static_cast<std::size_t>((i + 3) * 7)] = -1.0;  // not estimated
  }
  out.radar_used = state->radar_used;
  return true;
}

}  // namespace rsrio
