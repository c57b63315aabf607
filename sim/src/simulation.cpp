#include "rsrio/sim/simulation.hpp"

namespace rsrio::sim {

Simulation::Simulation(const Scenario& scenario, int threads) : scenario_(scenario) {
  trajectory_ = std::make_unique<SplineTrajectory>(scenario_.trajectory);
  duration_ = scenario_.effective_duration(*trajectory_);
  scene_ = std::make_unique<Scene>(scenario_.scene);
  radar_ = std::make_unique<RadarSimulator>(scenario_.radar, scenario_.radar_model, *scene_, *trajectory_,
                                            scenario_.rig.radar_in_imu, scenario_.seed, threads);
  imu_ = std::make_unique<ImuSimulator>(scenario_.imu, *trajectory_, scenario_.seed);
}

Simulation::~Simulation() = default;

std::uint64_t Simulation::radar_frames() const { return radar_->frames_until(duration_); }

}  // namespace rsrio::sim
