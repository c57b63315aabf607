// The RIO thread's work for one radar frame: the odometry core that rsrio-replay runs too
// (rsrio/rio/odometry.hpp: DSP -> ego-velocity -> frontend), turned into the PoseOutput the
// publisher sends. The core's buffers are sized at construction; its GTSAM optimiser is the one
// part that allocates.
#pragma once

#include <cstdint>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/rio/odometry.hpp"
#include "rsrio/runtime/odometry_publisher.hpp"

namespace rsrio {

class OdometryStage {
 public:
  OdometryStage(const RadarConfig& radar, const rio::OdometryOptions& options);

  void add_imu(const rio::ImuSample& sample);
  /// One frame stamped `t` (s, radar clock). False while the frontend cannot start yet (no IMU).
  bool add_frame(double t, const AdcCube& cube, PoseOutput& out);

  /// The last frame that gave a pose: its measurement time and the frontend's odom_T_body, and
  /// the DSP's result (valid until the next add_frame): what the backend takes.
  double last_t() const { return last_t_; }
  const gtsam::Pose3& last_odom_T_body() const { return last_odom_T_body_; }
  const DspResult& dsp_result() const { return odometry_.dsp().result(); }
  const rio::Odometry& odometry() const { return odometry_; }

  std::uint64_t frames() const { return frames_; }
  std::uint64_t ego_rejected() const { return ego_rejected_; }

 private:
  rio::Odometry odometry_;
  double last_t_ = 0;
  gtsam::Pose3 last_odom_T_body_;
  std::uint64_t frames_ = 0;
  std::uint64_t ego_rejected_ = 0;
};

}  // namespace rsrio
