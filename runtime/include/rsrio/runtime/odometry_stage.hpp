// The RIO thread's work for one radar frame: DSP -> ego-velocity -> frontend, turned into the
// PoseOutput the publisher sends. Buffers are sized at construction (the DSP's and the
// ego-velocity estimator's); the frontend's GTSAM optimiser is the one part that allocates.
#pragma once

#include <cstdint>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/dsp_options.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/rio/ego_velocity.hpp"
#include "rsrio/rio/frontend.hpp"
#include "rsrio/runtime/odometry_publisher.hpp"

namespace rsrio {

class OptionsNode;

struct OdometryStageOptions {
  DspOptions dsp;
  rio::EgoVelocityOptions ego_velocity;
  rio::FrontendOptions frontend;
};

class OdometryStage {
 public:
  OdometryStage(const RadarConfig& radar, const OdometryStageOptions& options);

  void add_imu(const rio::ImuSample& sample);
  /// One frame at radar time `t` (s). False while the frontend cannot start yet (no IMU).
  bool add_frame(double t, const AdcCube& cube, PoseOutput& out);

  std::uint64_t frames() const { return frames_; }
  std::uint64_t ego_rejected() const { return ego_rejected_; }

 private:
  DspProcessor dsp_;
  rio::EgoVelocityEstimator ego_;
  rio::RioFrontend frontend_;
  std::vector<rio::DopplerMeasurement> doppler_;
  rio::ImuSample last_imu_;
  std::uint64_t frames_ = 0;
  std::uint64_t ego_rejected_ = 0;
};

}  // namespace rsrio
