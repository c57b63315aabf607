// The radar-inertial odometry core that rsrio-replay and the real-time daemon share: one raw radar
// frame -> DSP points -> ego-velocity -> frontend state. No I/O; the caller feeds IMU samples and
// frames in time order and decides what to do with the result.
//
// Options come from one YAML file with sections (each strict: an unknown key is a ConfigError
// naming it):
//
//   dsp:           rsrio/dsp/dsp_options.hpp
//   ego_velocity:  EgoVelocityOptions (rsrio/rio/ego_velocity.hpp) + the point filter below
//   frontend:      FrontendOptions (rsrio/rio/frontend.hpp); the extrinsic as
//                  radar_translation_m [x, y, z] (radar origin in the IMU frame) and
//                  radar_rpy_deg [roll, pitch, yaw] (R = Rz Ry Rx), as the simulator's `rig:`
//
// config/rsrio.yaml lists every key with its default.
//
// Timing: a radar frame is stamped when its last chirp ends; its Doppler is the velocity averaged
// over the chirps, so the ego-velocity (and the state) belongs to the middle of the frame,
// stamp - frame_active_time / 2. FrameInfo::t is that time (radar clock).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/dsp_options.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/rio/ego_velocity.hpp"
#include "rsrio/rio/frontend.hpp"

namespace rsrio {
class OptionsNode;
}

namespace rsrio::rio {

/// Which DSP points become Doppler measurements.
struct PointFilterOptions {
  double min_range_m = 0.5;   // the nearest metre is leakage and the rig itself
  double min_snr_db = 10.0;   // coherent SNR of the point
  // Points whose azimuth may be a return wrapped from beyond the grid's edge
  // (DspPoint::azimuth_ambiguous; none on arrays spaced lambda/2 or closer). Their Doppler says
  // little about a forward walk either way, but in a turn on the spot the radar's own lateral
  // velocity (omega x lever arm) is all there is to see, and a wrapped return reads it with the
  // wrong sign: kept, they pull the lateral velocity towards zero (rio/RESULTS.md, 2026-12-06).
  bool drop_ambiguous_azimuth = false;
};

/// Whether `p` passes `filter`; the measurement it gives (unit direction, Doppler) if so.
bool accept_point(const PointFilterOptions& filter, const DspPoint& p, DopplerMeasurement& measurement);

struct OdometryOptions {
  DspOptions dsp;
  EgoVelocityOptions ego_velocity;
  PointFilterOptions points;
  FrontendOptions frontend;
};

/// Reads the `dsp`, `ego_velocity` and `frontend` sections of `root` (each optional, each strict).
OdometryOptions load_odometry_options(OptionsNode& root);
/// The options as YAML sections (what programs print at start-up; loadable again).
void print(std::ostream& out, const OdometryOptions& options);

/// What one radar frame gave.
struct FrameInfo {
  std::uint64_t index = 0;        // frames given so far - 1
  double t_stamp = 0;             // the frame's stamp (radar clock)
  double t = 0;                   // the frame's measurement time, see top
  int detections = 0;             // CFAR detections
  int points = 0;                 // DSP points
  int measurements = 0;           // points that passed the filter into the ego-velocity
  EgoVelocity ego;                // its status is the rejection reason
  std::optional<FrontendState> state;   // nullopt while the frontend cannot start
  gtsam::Pose3 world_T_radar;     // state pose composed with the extrinsic (valid with state)
  double dsp_ms = 0, ego_ms = 0, frontend_ms = 0;
};

class Odometry {
 public:
  /// Throws ConfigError for DSP options that do not fit the radar.
  Odometry(const RadarConfig& radar, const OdometryOptions& options);

  void add_imu(const ImuSample& sample) { frontend_.add_imu(sample); }
  /// Processes one frame stamped `t_stamp` (radar clock). The cube must have the configuration's
  /// shape (std::invalid_argument otherwise; nothing is changed then). The reference stays valid
  /// until the next call.
  const FrameInfo& add_radar_frame(double t_stamp, const AdcCube& cube);

  const OdometryOptions& options() const { return options_; }
  const RadarConfig& radar() const { return dsp_.config(); }
  const DspProcessor& dsp() const { return dsp_; }
  const RioFrontend& frontend() const { return frontend_; }
  /// The last frame's Doppler measurements (after the filter).
  std::span<const DopplerMeasurement> measurements() const { return measurements_; }

 private:
  OdometryOptions options_;
  DspProcessor dsp_;
  EgoVelocityEstimator ego_;
  RioFrontend frontend_;
  double half_frame_s_ = 0;
  std::vector<DopplerMeasurement> measurements_;  // reserved for the DSP's maximum point count
  FrameInfo info_;
  std::uint64_t frames_ = 0;
};

/// The extrinsic from the simulator's / config's form: translation (m) and roll, pitch, yaw (deg).
gtsam::Pose3 pose_from_xyz_rpy(const std::vector<double>& xyz, const std::vector<double>& rpy_deg);

}  // namespace rsrio::rio
