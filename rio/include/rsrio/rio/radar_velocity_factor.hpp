// The radar ego-velocity factor (loosely coupled, one per radar frame): the velocity of the radar
// frame predicted from the body state and the radar-IMU extrinsic, against the estimated ego-velocity.
//
//   h(T_WB, v_W, b) = R_BR^T ( R_WB^T v_W + (omega_B - b_g) x p_BR )        error = h - z
//
// T_BR = (R_BR, p_BR) is the radar pose in the body (IMU) frame, omega_B the gyro sample at the
// radar stamp (its lever-arm term omega x l is why the bias enters). Analytic Jacobians (GTSAM's
// right perturbation of Pose3, tangent [rotation, translation]; ConstantBias vector [acc, gyro]):
//   dh/dpose = [ R_BR^T [R_WB^T v_W]x | 0 ],  dh/dv_W = R_BR^T R_WB^T,  dh/db = [ 0 | R_BR^T [p_BR]x ]
// The sign of z follows ego_velocity.hpp: z is the radar's own velocity in the radar frame.
#pragma once

#include <gtsam/geometry/Pose3.h>
#include <gtsam/navigation/ImuBias.h>
#include <gtsam/nonlinear/NonlinearFactor.h>

namespace rsrio::rio {

class RadarVelocityFactor
    : public gtsam::NoiseModelFactorN<gtsam::Pose3, gtsam::Vector3, gtsam::imuBias::ConstantBias> {
  using Base = gtsam::NoiseModelFactorN<gtsam::Pose3, gtsam::Vector3, gtsam::imuBias::ConstantBias>;

 public:
  RadarVelocityFactor(gtsam::Key pose, gtsam::Key velocity, gtsam::Key bias, const gtsam::Vector3& measured,
                      const gtsam::Vector3& omega_body, const gtsam::Pose3& body_T_radar,
                      const gtsam::SharedNoiseModel& model);

  gtsam::Vector evaluateError(const gtsam::Pose3& world_T_body, const gtsam::Vector3& v_world,
                              const gtsam::imuBias::ConstantBias& bias,
                              boost::optional<gtsam::Matrix&> H_pose = boost::none,
                              boost::optional<gtsam::Matrix&> H_velocity = boost::none,
                              boost::optional<gtsam::Matrix&> H_bias = boost::none) const override;

  /// The predicted radar-frame velocity h(.) alone.
  gtsam::Vector3 predict(const gtsam::Pose3& world_T_body, const gtsam::Vector3& v_world,
                         const gtsam::imuBias::ConstantBias& bias) const;

  gtsam::NonlinearFactor::shared_ptr clone() const override;  // GTSAM 4.2's default throws

  const gtsam::Vector3& measured() const { return measured_; }

 private:
  gtsam::Vector3 measured_;
  gtsam::Vector3 omega_body_;
  gtsam::Rot3 body_R_radar_;
  gtsam::Point3 body_p_radar_;
};

}  // namespace rsrio::rio
