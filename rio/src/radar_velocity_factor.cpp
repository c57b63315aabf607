#include "rsrio/rio/radar_velocity_factor.hpp"

namespace rsrio::rio {

RadarVelocityFactor::RadarVelocityFactor(gtsam::Key pose, gtsam::Key velocity, gtsam::Key bias,
                                         const gtsam::Vector3& measured, const gtsam::Vector3& omega_body,
                                         const gtsam::Pose3& body_T_radar, const gtsam::SharedNoiseModel& model)
    : Base(model, pose, velocity, bias),
      measured_(measured),
      omega_body_(omega_body),
      body_R_radar_(body_T_radar.rotation()),
      body_p_radar_(body_T_radar.translation()) {}

gtsam::Vector3 RadarVelocityFactor::predict(const gtsam::Pose3& T, const gtsam::Vector3& v_W,
                                            const gtsam::imuBias::ConstantBias& b) const {
  const gtsam::Vector3 v_B = T.rotation().unrotate(v_W);
  return body_R_radar_.unrotate(v_B + (omega_body_ - b.gyroscope()).cross(body_p_radar_));
}

gtsam::Vector RadarVelocityFactor::evaluateError(const gtsam::Pose3& T, const gtsam::Vector3& v_W,
                                                 const gtsam::imuBias::ConstantBias& b,
                                                 boost::optional<gtsam::Matrix&> H_pose,
                                                 boost::optional<gtsam::Matrix&> H_velocity,
                                                 boost::optional<gtsam::Matrix&> H_bias) const {
  const gtsam::Matrix3 R_WB_T = T.rotation().transpose();
  const gtsam::Matrix3 R_BR_T = body_R_radar_.transpose();
  const gtsam::Vector3 v_B = R_WB_T * v_W;
  if (H_pose) {
    *H_pose = gtsam::Matrix::Zero(3, 6);
    H_pose->leftCols<3>() = R_BR_T * gtsam::skewSymmetric(v_B);
  }
  if (H_velocity) *H_velocity = R_BR_T * R_WB_T;
  if (H_bias) {
    *H_bias = gtsam::Matrix::Zero(3, 6);
    H_bias->rightCols<3>() = R_BR_T * gtsam::skewSymmetric(body_p_radar_);
  }
  return predict(T, v_W, b) - measured_;
}

gtsam::NonlinearFactor::shared_ptr RadarVelocityFactor::clone() const {
  return boost::static_pointer_cast<gtsam::NonlinearFactor>(
      gtsam::NonlinearFactor::shared_ptr(new RadarVelocityFactor(*this)));
}

}  // namespace rsrio::rio
