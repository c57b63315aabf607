// A simulation scenario: the world, the walk through it, the sensors. Loaded from a YAML file
// (schema with every key, unit and default: scenarios/README.md) through rsrio::OptionsFile, so a
// bad file is rejected as a whole with the file and the key named (rsrio::ConfigError).
#pragma once

#include <cstdint>
#include <string>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/sim/imu_simulator.hpp"
#include "rsrio/sim/motion.hpp"
#include "rsrio/sim/radar_simulator.hpp"
#include "rsrio/sim/scene.hpp"

namespace rsrio::sim {

/// How the sensors sit on the rig. The rig's body frame is the IMU frame, which the trajectory
/// moves; the radar is mounted on it.
struct RigOptions {
  Mount radar_in_imu;              // radar axes and origin in the IMU frame (lever arm)
  double imu_time_offset_s = 0.0;  // IMU header stamps = true time + offset (imperfect sync)
};

struct Scenario {
  std::string file;                     // where it was loaded from ("" when built in code)
  std::string name;
  std::string description;
  std::uint64_t seed = 1;               // radar thermal noise, IMU noise and biases
  double duration_s = 0;                // 0: the trajectory's duration
  double start_time_unix_s = 1.7e9;     // the epoch of scenario time 0, for message stamps
  RadarConfig radar;                    // section `radar`, as in config/radar/*.yaml
  RadarModelOptions radar_model;
  ImuOptions imu;
  RigOptions rig;
  TrajectoryOptions trajectory;
  SceneOptions scene;

  /// The duration actually simulated.
  double effective_duration(const SplineTrajectory& walk) const {
    return duration_s > 0 ? duration_s : walk.duration();
  }
};

/// Loads and validates a scenario file. Throws rsrio::ConfigError naming the file and the key.
Scenario load_scenario(const std::string& path);

}  // namespace rsrio::sim
