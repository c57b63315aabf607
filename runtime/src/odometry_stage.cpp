#include "rsrio/runtime/odometry_stage.hpp"

#include <cmath>

namespace rsrio {

OdometryStage::OdometryStage(const RadarConfig& radar, const OdometryStageOptions& options)
    : dsp_(radar, options.dsp), ego_(options.ego_velocity), frontend_(options.frontend) {
  doppler_.reserve(4096);
}

void OdometryStage::add_imu(const rio::ImuSample& sample) {
  frontend_.add_imu(sample);
  last_imu_ = sample;
}

bool OdometryStage::add_frame(double t, const AdcCube& cube, PoseOutput& out) {
  ++frames_;
  const DspResult& r = dsp_.process(cube);
  doppler_.clear();
  for (const DspPoint& p : r.points) {
    if (doppler_.size() == doppler_.capacity()) break;
    const double n = std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z);
    if (!(n > 1e-6)) continue;
    doppler_.push_back({Eigen::Vector3d(p.x / n, p.y / n, p.z / n), p.doppler_mps});
  }
  const rio::EgoVelocity ego = ego_.estimate(doppler_, frames_);
  if (!ego.ok()) ++ego_rejected_;
  const auto state = frontend_.add_radar(t, ego);
  if (!state) return false;

  const gtsam::Rot3 R = state->world_T_body.rotation();
  const gtsam::Point3 p = state->world_T_body.translation();
  const gtsam::Quaternion q = R.toQuaternion();
  out.position = {p.x(), p.y(), p.z()};
  out.orientation = {q.x(), q.y(), q.z(), q.w()};
  const gtsam::Vector3 v_body = R.unrotate(state->velocity_world);
  out.linear_velocity = {v_body.x(), v_body.y(), v_body.z()};
  const gtsam::Vector3 w = state->bias.correctGyroscope(last_imu_.gyro);
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
