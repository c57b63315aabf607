// One simulation run of a scenario: the rig walks the trajectory, the radar makes frames, the IMU
// makes samples, and the ground truth of both frames is there for any time.
//
// Clocks: everything is in scenario time t (s, 0 = start of the walk). Radar frames are stamped
// when their last chirp ends (frame_completion), as the capture hardware delivers them. IMU
// samples are taken at true times j / rate and stamped with true time + rig.imu_time_offset_s.
// Ground truth carries true times.
#pragma once

#include <cstdint>
#include <memory>

#include "rsrio/sim/imu_simulator.hpp"
#include "rsrio/sim/motion.hpp"
#include "rsrio/sim/radar_simulator.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/scene.hpp"

namespace rsrio::sim {

class Simulation {
 public:
  /// Builds the trajectory, the scene and both sensors. Throws std::invalid_argument for a
  /// scenario that validation let through but that cannot be built.
  explicit Simulation(const Scenario& scenario, int threads = 2);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  const Scenario& scenario() const { return scenario_; }
  /// Seconds simulated.
  double duration() const { return duration_; }
  const SplineTrajectory& trajectory() const { return *trajectory_; }
  const Scene& scene() const { return *scene_; }
  RadarSimulator& radar() { return *radar_; }
  ImuSimulator& imu() { return *imu_; }

  /// Ground truth of the IMU (body) frame and of the radar frame.
  RigState imu_state(double t) const { return trajectory_->state(t); }
  RigState radar_state(double t) const { return attached(trajectory_->state(t), scenario_.rig.radar_in_imu); }

  /// Radar frames that complete within the duration.
  std::uint64_t radar_frames() const;

 private:
  Scenario scenario_;
  std::unique_ptr<SplineTrajectory> trajectory_;
  std::unique_ptr<Scene> scene_;
  std::unique_ptr<RadarSimulator> radar_;
  std::unique_ptr<ImuSimulator> imu_;
  double duration_ = 0;
};

}  // namespace rsrio::sim
