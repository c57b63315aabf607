// rsrio-odometry-bench: time per radar frame of the odometry core's stages (DSP, ego-velocity,
// frontend) on simulated stretches of walking, p50 and p99 against the frame period. The frames
// are simulated in between (not timed); the odometry runs on one thread, as in rsrio-replay.
// Also the ego-velocity against the simulator's true radar velocity while walking (> 0.3 m/s):
// the mean and RMS of its direction error in the plane (positive: turned to the left) and the
// mean speed ratio. A mean direction error is a heading offset that no later stage can see (the
// trajectory is turned against the poses' yaw by it: the floor of the rotation APE). And over
// every frame with an ego-velocity, its normalised error against its own covariance,
// NEES = e^T C^-1 e, whose mean is 3 for a covariance that is right: sqrt(mean / 3) is the factor
// by which the covariance understates the error (the frontend's radar_velocity_sigma_scale).
//
//   rsrio-odometry-bench [--seconds S]   (default 12 s of each stretch, 30 s of the corridor ones)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <string>
#include <vector>

#include "rsrio/common/cli.hpp"
#include "rsrio/rio/odometry.hpp"
#include "rsrio/sim/simulation.hpp"

namespace {

struct Pct {
  double p50 = 0, p99 = 0;
};
Pct pct(std::vector<double> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5))]; };
  return {at(0.5), at(0.99)};
}

// `preset`: another radar on the same walk (as rsrio-sim --radar: the scenario's frame period kept).
void bench(const std::string& label, const std::string& scenario_path, double seconds, const char* preset = nullptr) {
  rsrio::sim::Scenario s = rsrio::sim::load_scenario(scenario_path);
  s.duration_s = seconds;
  if (preset != nullptr) {
    const double period = s.radar.frame_period_ms;
    s.radar = rsrio::radar_preset(preset);
    s.radar.frame_period_ms = period;
  }
  rsrio::sim::Simulation sim(s, 2);
  rsrio::rio::OdometryOptions o;
  o.frontend.body_T_radar = gtsam::Pose3(gtsam::Rot3(s.rig.radar_in_imu.rotation), s.rig.radar_in_imu.translation);
  o.frontend.radar_time_offset_s = s.rig.imu_time_offset_s;
  rsrio::rio::Odometry odometry(s.radar, o);
  rsrio::AdcCube cube = rsrio::AdcCube::for_config(s.radar);
  std::vector<double> dsp, ego, frontend, total, direction_deg, speed_ratio, nees;
  double points = 0;
  for (std::uint64_t k = 0; k < sim.radar_frames(); ++k) {
    const double t = sim.radar().frame_completion(k);
    while (sim.imu().next_time() <= t) {
      const auto m = sim.imu().next();
      odometry.add_imu({m.time + s.rig.imu_time_offset_s, m.linear_acceleration, m.angular_velocity});
    }
    sim.radar().simulate(k, cube);
    const auto& f = odometry.add_radar_frame(t, cube);
    dsp.push_back(f.dsp_ms);
    ego.push_back(f.ego_ms);
    frontend.push_back(f.frontend_ms);
    total.push_back(f.dsp_ms + f.ego_ms + f.frontend_ms);
    points += f.points;
    if (f.ego.ok()) {
      const rsrio::sim::RigState truth = sim.radar_state(f.t);
      const Eigen::Vector3d v = truth.rotation.transpose() * truth.velocity;  // radar axes
      const Eigen::Vector3d error = f.ego.velocity - v;
      nees.push_back(error.dot(f.ego.covariance.ldlt().solve(error)));
      if (v.head<2>().norm() > 0.3) {
        const Eigen::Vector3d& e = f.ego.velocity;
        direction_deg.push_back(std::remainder(std::atan2(e.y(), e.x()) - std::atan2(v.y(), v.x()), 2 * std::numbers::pi) *
                                180 / std::numbers::pi);
        speed_ratio.push_back(e.head<2>().norm() / v.head<2>().norm());
      }
    }
  }
  const auto a = pct(dsp), b = pct(ego), c = pct(frontend), d = pct(total);
  const double period = s.radar.frame_period_ms;
  const auto mean = [](const std::vector<double>& x) {
    return x.empty() ? 0.0 : std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
  };
  const double rms = std::sqrt(
      std::inner_product(direction_deg.begin(), direction_deg.end(), direction_deg.begin(), 0.0) /
      static_cast<double>(std::max<std::size_t>(1, direction_deg.size())));
  std::printf(
      "%-28s %6zu %7.0f | %7.2f %7.2f | %6.3f %6.3f | %7.2f %7.2f | %7.2f %7.2f | %6.0f %7.2f | %+6.2f %5.2f %7.4f | "
      "%6.1f %5.2f\n",
      label.c_str(), dsp.size(), points / std::max<std::size_t>(1, dsp.size()), a.p50, a.p99, b.p50, b.p99, c.p50, c.p99,
      d.p50, d.p99, period, period / std::max(d.p50, 1e-9), mean(direction_deg), rms, mean(speed_ratio), mean(nees),
      std::sqrt(mean(nees) / 3));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  std::string seconds_text = "12";
  rsrio::Cli cli("rsrio-odometry-bench", "Time per radar frame of DSP, ego-velocity and frontend on simulated walks.");
  cli.option("--seconds", "S", "seconds of each stretch (default 12)", &seconds_text);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  const double seconds = std::stod(seconds_text);
  std::printf("rsrio-odometry-bench: ms per radar frame, one thread (frames simulated in between, not timed)\n\n");
  std::printf("%-28s %6s %7s | %15s | %13s | %15s | %15s | %14s | %s | %s\n", "stretch", "frames", "points",
              "DSP p50/p99", "ego p50/p99", "frontend p50/p99", "total p50/p99", "period  x rt",
              "ego dir mean/RMS deg, speed", "NEES sqrt(/3)");
  bench("test_tiny (xwr1843, 16 loops)", "scenarios/test_tiny.yaml", std::min(seconds, 6.4));
  bench("seq2 start (mmwcas)", "scenarios/seq2_small_loop.yaml", seconds);
  // Straight down sequence 3's corridor (walls on both sides), 2.5x as long: the direction
  // error's mean is the point of these rows, and its frame-to-frame scatter is ~2 deg.
  bench("seq3 corridor (mmwcas)", "scenarios/seq3_large_loop.yaml", 2.5 * seconds);
  bench("seq3 corridor (xwr1843)", "scenarios/seq3_large_loop.yaml", 2.5 * seconds, "xwr1843");
  // Sequence 1's first legs at 0.42 m/s (its speed ratio is the scale the backend inherits).
  bench("seq1 room (mmwcas)", "scenarios/seq1_meeting_room.yaml", 2.5 * seconds);
  return 0;
}
