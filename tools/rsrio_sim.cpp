// rsrio-sim: simulates a scenario (scenarios/*.yaml) into a recording: raw radar frames exactly as
// the capture hardware delivers them (/radar/raw), the IMU (/imu) and the radar frame's ground
// truth (/ground_truth), in log-time order. Exit 0 on success, 2 for a bad command line or
// scenario, 1 when the recording cannot be written.
#include <unistd.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <limits>
#include <string>

#include <Eigen/Geometry>

#include "cli_numbers.hpp"
#include "rsrio/common/cli.hpp"
#include "rsrio/common/log.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/recording/recording.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"

namespace {

using rsrio::tools::parse_double;
using rsrio::tools::parse_u64;

constexpr const char* kProgram = "rsrio-sim";

// Scenario seconds -> nanoseconds since the epoch.
std::uint64_t epoch_ns(double start_unix_s, double t) {
  return static_cast<std::uint64_t>(std::llround(start_unix_s * 1e9) + std::llround(t * 1e9));
}

void set_stamp(builtin_interfaces::msg::Time& stamp, std::uint64_t ns) {
  stamp.sec(static_cast<std::int32_t>(ns / 1'000'000'000ull));
  stamp.nanosec(static_cast<std::uint32_t>(ns % 1'000'000'000ull));
}

void set_vector(geometry_msgs::msg::Vector3& v, const Eigen::Vector3d& e) {
  v.x(e.x());
  v.y(e.y());
  v.z(e.z());
}

sensor_msgs::msg::Imu imu_message(const rsrio::sim::ImuSample& s, std::uint64_t stamp_ns, double gyro_var,
                                  double accel_var) {
  sensor_msgs::msg::Imu m;
  set_stamp(m.header().stamp(), stamp_ns);
  m.header().frame_id("imu");
  // No orientation estimate: REP-145 / sensor_msgs convention, covariance[0] = -1.
  m.orientation().w(0.0);
  m.orientation_covariance()[0] = -1;
  set_vector(m.angular_velocity(), s.angular_velocity);
  set_vector(m.linear_acceleration(), s.linear_acceleration);
  for (int i = 0; i < 3; ++i) {
    m.angular_velocity_covariance()[4 * i] = gyro_var;
    m.linear_acceleration_covariance()[4 * i] = accel_var;
  }
  return m;
}

nav_msgs::msg::Odometry ground_truth_message(const rsrio::sim::RigState& radar, std::uint64_t stamp_ns) {
  nav_msgs::msg::Odometry m;
  set_stamp(m.header().stamp(), stamp_ns);
  m.header().frame_id("map");
  m.child_frame_id("radar");
  auto& pose = m.pose().pose();
  pose.position().x(radar.position.x());
  pose.position().y(radar.position.y());
  pose.position().z(radar.position.z());
  const Eigen::Quaterniond q(radar.rotation);
  pose.orientation().w(q.w());
  pose.orientation().x(q.x());
  pose.orientation().y(q.y());
  pose.orientation().z(q.z());
  // Twist in the child (radar) frame, as nav_msgs/Odometry defines it.
  set_vector(m.twist().twist().linear(), radar.rotation.transpose() * radar.velocity);
  set_vector(m.twist().twist().angular(), radar.angular_velocity);
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario_path, out_path, seconds_text, seed_text, radar_text, threads_text = "2";
  bool rosbag2 = false;
  rsrio::Cli cli(kProgram,
                 "Simulate a scenario (scenarios/*.yaml) into an MCAP recording: raw radar frames (/radar/raw),\n"
                 "IMU (/imu) and the radar's ground truth (/ground_truth).");
  cli.option("--scenario", "FILE", "the scenario to simulate (required)", &scenario_path);
  cli.option("--out", "REC.mcap", "the recording to write (required; replaced if it exists)", &out_path);
  cli.option("--seconds", "S", "simulate only the first S seconds", &seconds_text);
  cli.option("--seed", "N", "noise seed (radar thermal noise, IMU noise and biases) instead of the scenario's",
             &seed_text);
  cli.option("--radar", "PRESET", "radar preset (xwr1843, mmwcas) instead of the scenario's; keeps its frame period",
             &radar_text);
  cli.option("--threads", "N", "worker threads for the radar (default 2)", &threads_text);
  cli.flag("--rosbag2",
           "also write metadata.yaml beside the recording: its directory becomes a rosbag2 bag (for tools\n"
           "      that open only bag directories, such as python3-rosbags; name the file DIR/NAME_0.mcap)",
           &rosbag2);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  if (auto rc = rsrio::load_program_config(cli, kProgram, [](rsrio::OptionsNode&) {})) return *rc;

  if (scenario_path.empty()) return cli.usage_error("--scenario FILE is required");
  if (out_path.empty()) return cli.usage_error("--out REC.mcap is required");
  double seconds = 0;
  if (!seconds_text.empty() && (!parse_double(seconds_text, seconds) || seconds <= 0))
    return cli.usage_error("--seconds: expected a positive number of seconds, got '" + seconds_text + "'");
  std::uint64_t seed = 0, threads = 0;
  if (!seed_text.empty() && !parse_u64(seed_text, seed))
    return cli.usage_error("--seed: expected a non-negative integer, got '" + seed_text + "'");
  if (!parse_u64(threads_text, threads) || threads < 1 || threads > 64)
    return cli.usage_error("--threads: expected an integer in [1, 64], got '" + threads_text + "'");

  rsrio::sim::Scenario scenario;
  try {
    scenario = rsrio::sim::load_scenario(scenario_path);
  } catch (const rsrio::ConfigError& e) {
    std::cerr << kProgram << ": error: " << e.what() << "\n";
    return rsrio::kExitUsage;
  }
  if (!seed_text.empty()) scenario.seed = seed;
  if (!radar_text.empty()) {
    try {
      const double period = scenario.radar.frame_period_ms;
      scenario.radar = rsrio::radar_preset(radar_text);
      scenario.radar.frame_period_ms = period;
      rsrio::validate(scenario.radar, "--radar " + radar_text, "radar");
    } catch (const std::invalid_argument&) {
      std::string names;
      for (auto p : rsrio::radar_presets()) names += " " + std::string(p);
      return cli.usage_error("--radar: expected one of" + names + ", got '" + radar_text + "'");
    } catch (const rsrio::ConfigError& e) {
      return cli.usage_error(std::string(e.what()));
    }
  }

  std::unique_ptr<rsrio::sim::Simulation> sim;
  try {
    sim = std::make_unique<rsrio::sim::Simulation>(scenario, static_cast<int>(threads));
  } catch (const std::invalid_argument& e) {
    std::cerr << kProgram << ": error: " << scenario_path << ": " << e.what() << "\n";
    return rsrio::kExitUsage;
  }
  const double duration = seconds > 0 ? seconds : sim->duration();
  rsrio::sim::RadarSimulator& radar = sim->radar();
  rsrio::sim::ImuSimulator& imu = sim->imu();
  const std::uint64_t frames = radar.frames_until(duration);
  const double start_unix = scenario.start_time_unix_s;
  const double imu_offset = scenario.rig.imu_time_offset_s;
  const double gyro_var = std::pow(imu.gyro_sigma(), 2), accel_var = std::pow(imu.accel_sigma(), 2);

  spdlog::info("{}: {} s, {} radar frames ({} at {} ms), IMU at {} Hz, seed {}, {} thread(s) -> {}", scenario.name,
               duration, frames, scenario.radar.preset, scenario.radar.frame_period_ms, scenario.imu.rate_hz,
               scenario.seed, threads, out_path);
  try {
    rsrio::RecordingWriterOptions writer_options;
    writer_options.write_rosbag2_metadata = rosbag2;
    rsrio::RecordingWriter writer(out_path, writer_options);
    rsrio_msgs::msg::RadarFrame frame_msg;
    frame_msg.header().frame_id("radar");
    frame_msg.flags(rsrio_msgs::msg::RadarFrame_Constants::FLAG_SIMULATED);
    frame_msg.lost_bytes(0);
    frame_msg.config(rsrio::to_msg(radar.config()));
    std::uint64_t imu_samples = 0, saturated = 0;
    // IMU samples and ground truth up to time t, in order: log time = true sample time (when it
    // arrives), header stamp = the IMU's own clock (true time + offset).
    auto write_imu_until = [&](double t) {
      while (imu.next_time() <= t) {
        const rsrio::sim::ImuSample s = imu.next();
        const std::uint64_t log_ns = epoch_ns(start_unix, s.time);
        writer.write(rsrio::topics::kImu, imu_message(s, epoch_ns(start_unix, s.time + imu_offset), gyro_var, accel_var),
                     log_ns);
        writer.write(rsrio::topics::kGroundTruth, ground_truth_message(sim->radar_state(s.time), log_ns), log_ns);
        ++imu_samples;
      }
    };
    const bool tty = isatty(STDERR_FILENO) != 0;
    const auto wall_start = std::chrono::steady_clock::now();
    auto last_report = wall_start;

    // Two frame buffers: the radar simulates frame k + 1 into one while this recorder thread
    // encodes and writes frame k (and the IMU up to it) from the other; encoding and writing 3 MB
    // take about as long as simulating. All writing happens on the recorder, in log-time order.
    struct Slot {
      rsrio::AdcCube cube;
      rsrio::sim::FrameStats stats;
      bool full = false;
    };
    std::array<Slot, 2> slots;
    std::mutex mutex;
    std::condition_variable changed;
    bool abort = false;
    std::exception_ptr recorder_error;
    std::thread recorder([&] {
      try {
        for (std::uint64_t k = 0; k < frames; ++k) {
          Slot& slot = slots[k % 2];
          {
            std::unique_lock lock(mutex);
            changed.wait(lock, [&] { return slot.full || abort; });
            if (abort) return;
          }
          const double done_t = radar.frame_completion(k);
          write_imu_until(done_t);
          saturated += slot.stats.saturated_samples;
          rsrio::encode_frame(radar.config(), slot.cube, frame_msg.adc());
          const std::size_t visible = slot.stats.visible_scatterers;
          {
            std::lock_guard lock(mutex);
            slot.full = false;
          }
          changed.notify_all();
          const std::uint64_t ns = epoch_ns(start_unix, done_t);
          set_stamp(frame_msg.header().stamp(), ns);
          frame_msg.frame_number(k);
          frame_msg.monotonic_ns(static_cast<std::uint64_t>(std::llround(done_t * 1e9)));
          writer.write(rsrio::topics::kRadarRaw, frame_msg, ns);

          const auto now = std::chrono::steady_clock::now();
          if (now - last_report > std::chrono::seconds(2) || k + 1 == frames) {
            last_report = now;
            const double wall = std::chrono::duration<double>(now - wall_start).count();
            const double rtf = done_t / std::max(wall, 1e-9);
            const double left = (duration - done_t) / std::max(rtf, 1e-9);
            std::fprintf(stderr, "%s: frame %llu/%llu (%.0f %%), %.1f of %.1f s, %.2fx real time, %.0f s left, %zu visible%s",
                         kProgram, static_cast<unsigned long long>(k + 1), static_cast<unsigned long long>(frames),
                         100.0 * static_cast<double>(k + 1) / static_cast<double>(frames), done_t, duration, rtf, left,
                         visible, tty ? "   \r" : "\n");
          }
        }
      } catch (...) {
        std::lock_guard lock(mutex);
        recorder_error = std::current_exception();
        abort = true;
        changed.notify_all();
      }
    });
    try {
      for (std::uint64_t k = 0; k < frames; ++k) {
        Slot& slot = slots[k % 2];
        {
          std::unique_lock lock(mutex);
          changed.wait(lock, [&] { return !slot.full || abort; });
          if (abort) break;
        }
        slot.stats = radar.simulate(k, slot.cube);
        {
          std::lock_guard lock(mutex);
          slot.full = true;
        }
        changed.notify_all();
      }
    } catch (...) {
      {
        std::lock_guard lock(mutex);
        abort = true;
      }
      changed.notify_all();
      recorder.join();
      throw;
    }
    recorder.join();
    if (recorder_error) std::rethrow_exception(recorder_error);
    write_imu_until(duration);
    writer.close();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    if (tty) std::fprintf(stderr, "\n");
    if (saturated > 0)
      spdlog::warn("{} ADC samples saturated at int16 (clipped, as the real ADC would)", saturated);
    spdlog::info("wrote {}: {} radar frames, {} IMU samples, {:.1f} s simulated in {:.1f} s ({:.2f}x real time)",
                 out_path, frames, imu_samples, duration, wall, duration / std::max(wall, 1e-9));
  } catch (...) {
    return rsrio::report_program_error(kProgram, std::current_exception());
  }
  return 0;
}
