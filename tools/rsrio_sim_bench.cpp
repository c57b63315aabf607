// rsrio-sim-bench: how fast the raw-ADC radar simulator makes frames, per radar preset and number
// of visible scatterers, on the threads it is given (default 2), against the frame rate the real
// radar runs at (real-time factor = simulated seconds per wall-clock second). Also one shipped
// scenario, walked end to end, for a realistic mix of scatterers.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/cli.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/sim/motion.hpp"
#include "rsrio/sim/radar_simulator.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"

namespace {

using Clock = std::chrono::steady_clock;

struct Row {
  std::string what;
  double visible = 0;
  double ms_per_frame = 0, encode_ms = 0;
  double frame_period_s = 0;
};

void print_row(const Row& r) {
  const double fps = 1000.0 / r.ms_per_frame;
  std::printf("%-26s %9.0f %11.1f %10.1f %9.2f %10.2fx\n", r.what.c_str(), r.visible, r.ms_per_frame, r.encode_ms, fps,
              fps * r.frame_period_s);
  std::fflush(stdout);
}

Row bench_points(const std::string& preset, int points, int threads, int frames) {
  const rsrio::RadarConfig config = rsrio::radar_preset(preset);
  const double max_range = rsrio::derive(config).max_range_m;
  rsrio::sim::SceneOptions so;
  rsrio::sim::ClutterOptions c;
  c.region = Eigen::Vector4d(1.0, -8.0, 0.8 * max_range, 8.0);  // all in front and in range
  c.z_min_m = 0.5;
  c.z_max_m = 1.5;
  c.count = points;
  c.rcs_m2 = 0.1;
  so.clutter.push_back(c);
  const rsrio::sim::Scene scene(so);
  const rsrio::sim::LinearMotion body(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.7, 0.05, 0),
                                      Eigen::Matrix3d::Identity(), 100);
  rsrio::sim::RadarSimulator sim(config, rsrio::sim::RadarModelOptions{}, scene, body, rsrio::sim::Mount{}, 1, threads);
  rsrio::AdcCube cube;
  std::vector<std::uint8_t> bytes;
  sim.simulate(0, cube);  // warm-up: first-touch of every buffer
  Row row;
  row.what = preset + " points";
  row.frame_period_s = config.frame_period_ms * 1e-3;
  double visible = 0, encode_s = 0;
  const auto t0 = Clock::now();
  for (int k = 1; k <= frames; ++k) visible += static_cast<double>(sim.simulate(k, cube).visible_scatterers);
  const double sim_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto t1 = Clock::now();
  for (int k = 0; k < frames; ++k) rsrio::encode_frame(config, cube, bytes);
  encode_s = std::chrono::duration<double>(Clock::now() - t1).count();
  row.visible = visible / frames;
  row.ms_per_frame = 1e3 * sim_s / frames;
  row.encode_ms = 1e3 * encode_s / frames;
  return row;
}

Row bench_scenario(const std::string& path, const std::string& preset, int threads, int frames) {
  rsrio::sim::Scenario scenario = rsrio::sim::load_scenario(path);
  if (!preset.empty()) {
    const double period = scenario.radar.frame_period_ms;
    scenario.radar = rsrio::radar_preset(preset);
    scenario.radar.frame_period_ms = period;
  }
  rsrio::sim::Simulation sim(scenario, threads);
  rsrio::AdcCube cube;
  std::vector<std::uint8_t> bytes;
  const std::uint64_t total = sim.radar_frames();
  Row row;
  row.what = scenario.name + " (" + scenario.radar.preset + ")";
  row.frame_period_s = scenario.radar.frame_period_ms * 1e-3;
  sim.radar().simulate(0, cube);
  double visible = 0, sim_s = 0, encode_s = 0;
  for (int i = 0; i < frames; ++i) {
    const std::uint64_t k = total * static_cast<std::uint64_t>(i) / static_cast<std::uint64_t>(frames);  // spread over the walk
    const auto t0 = Clock::now();
    visible += static_cast<double>(sim.radar().simulate(k, cube).visible_scatterers);
    const auto t1 = Clock::now();
    rsrio::encode_frame(sim.radar().config(), cube, bytes);
    const auto t2 = Clock::now();
    sim_s += std::chrono::duration<double>(t1 - t0).count();
    encode_s += std::chrono::duration<double>(t2 - t1).count();
  }
  row.visible = visible / frames;
  row.ms_per_frame = 1e3 * sim_s / frames;
  row.encode_ms = 1e3 * encode_s / frames;
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  std::string threads_text = "2", frames_text = "10", scenario = "scenarios/seq3_large_loop.yaml";
  rsrio::Cli cli("rsrio-sim-bench", "Benchmark the raw-ADC radar simulator: frames/s and real-time factor.");
  cli.option("--threads", "N", "worker threads (default 2)", &threads_text);
  cli.option("--frames", "N", "frames timed per row (default 10)", &frames_text);
  cli.option("--scenario", "FILE", "scenario for the end-to-end rows (default scenarios/seq3_large_loop.yaml)", &scenario);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  int threads = 0, frames = 0;
  try {
    threads = std::stoi(threads_text);
    frames = std::stoi(frames_text);
  } catch (const std::exception&) {
    return cli.usage_error("--threads and --frames take whole numbers");
  }
  if (threads < 1 || frames < 1) return cli.usage_error("--threads and --frames must be at least 1");
  std::printf("rsrio-sim-bench: radar frames on %d thread(s), %d frames per row; noise, leakage and IF filters on\n",
              threads, frames);
  std::printf("%-26s %9s %11s %10s %9s %11s\n", "preset / scenario", "visible", "sim ms/frm", "encode ms", "frames/s",
              "real-time");
  for (const char* preset : {"mmwcas", "xwr1843"})
    for (int n : {250, 1000, 2000, 4000}) print_row(bench_points(preset, n, threads, frames));
  try {
    for (const char* preset : {"mmwcas", "xwr1843"}) print_row(bench_scenario(scenario, preset, threads, frames));
  } catch (const std::exception& e) {
    std::cerr << "rsrio-sim-bench: scenario rows skipped: " << e.what() << "\n";
  }
  std::printf("real-time = simulated time per wall-clock time (>= 1: faster than the radar makes frames)\n");
  return 0;
}
