// rsrio-dca1000-emu: a DCA1000EVM on loopback. Answers the board's command protocol on ADDR
// (default 127.0.0.2:4096, the Dca1000Emulator) and, while recording, streams the simulator's raw
// ADC of a scenario at its frame rate to the host's data port, with injected packet faults.
// The DCA1000 carries one xWR1843, so mmwcas scenarios are refused. The scenario repeats until
// stopped (frame numbers go on), or plays once with --once. SIGINT / SIGTERM stop it; the counters
// are printed on exit.
//
// The rest of the robot, for the demo and end-to-end tests: --imu-topic publishes the scenario's
// IMU as sensor_msgs/msg/Imu over DDS, and --ground-truth writes the IMU's true pose as a TUM file,
// both stamped on the wall clock the driver stamps frames with: scenario time t maps to
// W0 + (t - completion of frame 0), W0 being the moment the first frame is sent.
// Exit 0 on a clean stop, 2 for a bad command line or scenario, 1 when the socket cannot be bound.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cli_numbers.hpp"
#include "rsrio/common/cli.hpp"
#include "rsrio/common/log.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/common/spsc_queue.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/driver/dca1000_emulator.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/runtime/dds.hpp"
#include "rsrio/sim/simulation.hpp"
#include "sensor_msgs/msg/ImuPubSubTypes.hpp"

namespace {

constexpr const char* kProgram = "rsrio-dca1000-emu";

std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
extern "C" void on_signal(int) { g_stop.store(true); }

}  // namespace

int main(int argc, char** argv) {
  // First of all: a stop request during the scenario's set-up must still end in a clean exit.
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  using rsrio::tools::parse_double;
  using rsrio::tools::parse_probability;
  using rsrio::tools::parse_u64;
  std::string scenario_path, loss_text = "0", reorder_text = "0", duplicate_text = "0", stall_text = "0",
                             stall_every_text = "50", seed_text = "1", address_text = "127.0.0.2:4096",
                             host_data_text = "127.0.0.1:4098", threads_text = "2", imu_topic, domain_text = "0",
                             ground_truth_path, imu_gap_text;
  bool once = false;
  rsrio::Cli cli(kProgram,
                 "Emulate a DCA1000EVM + xWR1843 on loopback: answer the DCA1000 command protocol and, while\n"
                 "recording, stream a simulated scenario's raw ADC at its frame rate, with packet faults.");
  cli.option("--scenario", "FILE", "the scenario to stream (required; its radar must be the xwr1843 kind)",
             &scenario_path);
  cli.option("--loss", "P", "probability that a data packet is never sent (default 0)", &loss_text);
  cli.option("--reorder", "P", "probability that a packet is held back 1-8 packets (default 0)", &reorder_text);
  cli.option("--duplicate", "P", "probability that a packet is sent twice (default 0)", &duplicate_text);
  cli.option("--stall", "MS", "pause the stream this long every --stall-every frames (default 0: never)",
             &stall_text);
  cli.option("--stall-every", "N", "frames between stalls (default 50)", &stall_every_text);
  cli.option("--seed", "N", "seed of the fault pattern (default 1)", &seed_text);
  cli.option("--address", "ADDR", "the board's command address IP[:PORT] (default 127.0.0.2:4096)", &address_text);
  cli.option("--host-data", "ADDR", "where the data stream goes, IP[:PORT] (default 127.0.0.1:4098)",
             &host_data_text);
  cli.option("--threads", "N", "simulator threads (default 2)", &threads_text);
  cli.flag("--once", "stream the scenario once, then exit (default: repeat until stopped)", &once);
  cli.option("--imu-topic", "NAME", "also publish the scenario's IMU on this ROS 2 topic over DDS (e.g. /imu)",
             &imu_topic);
  cli.option("--domain", "ID", "DDS domain for --imu-topic (default 0)", &domain_text);
  cli.option("--imu-gap", "START:SECONDS", "publish no IMU for SECONDS from START s after the first frame "
             "(a silent IMU; radar goes on)", &imu_gap_text);
  cli.option("--ground-truth", "FILE", "write the IMU's true pose as a TUM trajectory on the stream's clock",
             &ground_truth_path);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  if (auto rc = rsrio::load_program_config(cli, kProgram, [](rsrio::OptionsNode&) {})) return *rc;

  if (scenario_path.empty()) return cli.usage_error("--scenario FILE is required");
  rsrio::EmulatorOptions options;
  auto& f = options.faults;
  if (!parse_probability(loss_text, f.loss)) return cli.usage_error("--loss: expected a probability in [0, 1], got '" + loss_text + "'");
  if (!parse_probability(reorder_text, f.reorder))
    return cli.usage_error("--reorder: expected a probability in [0, 1], got '" + reorder_text + "'");
  if (!parse_probability(duplicate_text, f.duplicate))
    return cli.usage_error("--duplicate: expected a probability in [0, 1], got '" + duplicate_text + "'");
  std::uint64_t stall = 0, stall_every = 0, threads = 0;
  if (!parse_u64(stall_text, stall) || stall > 60000)
    return cli.usage_error("--stall: expected milliseconds in [0, 60000], got '" + stall_text + "'");
  if (!parse_u64(stall_every_text, stall_every) || stall_every < 1 || stall_every > 1000000)
    return cli.usage_error("--stall-every: expected a number of frames >= 1, got '" + stall_every_text + "'");
  if (!parse_u64(seed_text, f.seed)) return cli.usage_error("--seed: expected a non-negative integer, got '" + seed_text + "'");
  if (!parse_u64(threads_text, threads) || threads < 1 || threads > 64)
    return cli.usage_error("--threads: expected an integer in [1, 64], got '" + threads_text + "'");
  std::uint64_t domain = 0;
  if (!parse_u64(domain_text, domain) || domain > 232)
    return cli.usage_error("--domain: expected an integer in [0, 232], got '" + domain_text + "'");
  if (!imu_topic.empty() && imu_topic.front() != '/')
    return cli.usage_error("--imu-topic: expected a ROS 2 topic name starting with '/', got '" + imu_topic + "'");
  if ((!imu_topic.empty() || !ground_truth_path.empty()) && !once)
    return cli.usage_error("--imu-topic and --ground-truth need --once (a repeated scenario would jump back in time)");
  double imu_gap_start = 0, imu_gap_s = 0;
  if (!imu_gap_text.empty()) {
    const auto colon = imu_gap_text.find(':');
    if (colon == std::string::npos || !parse_double(imu_gap_text.substr(0, colon), imu_gap_start) ||
        !parse_double(imu_gap_text.substr(colon + 1), imu_gap_s) || imu_gap_start < 0 || imu_gap_s <= 0)
      return cli.usage_error("--imu-gap: expected START:SECONDS (non-negative start, positive length), got '" +
                             imu_gap_text + "'");
    if (imu_topic.empty()) return cli.usage_error("--imu-gap needs --imu-topic");
  }
  f.stall_ms = static_cast<int>(stall);
  f.stall_every_frames = static_cast<int>(stall_every);
  try {
    options.board = rsrio::Endpoint::parse(address_text, rsrio::dca1000::kConfigPort);
    options.host_data = rsrio::Endpoint::parse(host_data_text, rsrio::dca1000::kDataPort);
  } catch (const std::invalid_argument& e) {
    return cli.usage_error(std::string("--address/--host-data: ") + e.what());
  }

  rsrio::sim::Scenario scenario;
  try {
    scenario = rsrio::sim::load_scenario(scenario_path);
  } catch (const rsrio::ConfigError& e) {
    std::cerr << kProgram << ": error: " << e.what() << "\n";
    return rsrio::kExitUsage;
  }
  if (scenario.radar.capture.format != "dca1000")
    return cli.usage_error(scenario_path + ": its radar is the '" + scenario.radar.preset +
                           "' preset (capture format '" + scenario.radar.capture.format +
                           "'): a DCA1000 carries one xWR1843 and streams only the dca1000 format; use an xwr1843 "
                           "scenario (cascade recordings are made with rsrio-sim --radar mmwcas)");
  std::unique_ptr<rsrio::sim::Simulation> sim;
  try {
    sim = std::make_unique<rsrio::sim::Simulation>(scenario, static_cast<int>(threads));
  } catch (const std::invalid_argument& e) {
    std::cerr << kProgram << ": error: " << scenario_path << ": " << e.what() << "\n";
    return rsrio::kExitUsage;
  }
  rsrio::sim::RadarSimulator& radar = sim->radar();
  const std::uint64_t scenario_frames = radar.frames_until(sim->duration());
  if (g_stop.load()) return 0;
  if (scenario_frames == 0) return cli.usage_error(scenario_path + ": the scenario completes no radar frame");
  const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(scenario.radar.frame_period_ms * 1e6));

  std::unique_ptr<rsrio::Dca1000Emulator> emulator;
  try {
    emulator = std::make_unique<rsrio::Dca1000Emulator>(options);
  } catch (const std::system_error& e) {
    std::cerr << kProgram << ": error: " << e.what()
              << " (is another emulator running there? 127.0.0.0/8 addresses need no setup)\n";
    return 1;
  }
  spdlog::info("{}: board at {}, data to {}; {} ({} frames of {} bytes every {} ms, repeated); faults: loss {}, "
               "reorder {}, duplicate {}, stall {} ms every {} frames, seed {}",
               kProgram, emulator->config_endpoint().to_string(), options.host_data.to_string(), scenario.name,
               scenario_frames, rsrio::dca1000_frame_bytes(scenario.radar), scenario.radar.frame_period_ms, f.loss,
               f.reorder, f.duplicate, f.stall_ms, f.stall_every_frames, f.seed);

  // The simulator runs ahead on its own thread into a few frame buffers; the board thread (this
  // one) sends them on the frame clock, as the radar's frame trigger would.
  constexpr std::uint32_t kBuffers = 4;
  std::vector<std::vector<std::uint8_t>> buffers(kBuffers);
  rsrio::SpscQueue<std::uint32_t> full(kBuffers), free_buffers(kBuffers);
  for (std::uint32_t i = 0; i < kBuffers; ++i) free_buffers.try_push(i);
  std::thread producer([&] {
    rsrio::AdcCube cube;
    std::uint64_t k = 0;
    while (!g_stop.load() && !(once && k == scenario_frames)) {
      std::uint32_t i = 0;
      if (!free_buffers.try_pop(i)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      radar.simulate(k % scenario_frames, cube);
      rsrio::encode_frame(radar.config(), cube, buffers[i]);
      full.try_push(i);  // cannot fail: kBuffers indexes circulate through two queues of kBuffers
      ++k;
    }
  });

  // IMU and ground truth on the stream's clock, from their own thread once the stream starts.
  std::unique_ptr<rsrio::DdsParticipant> dds;
  eprosima::fastdds::dds::DataWriter* imu_writer = nullptr;
  if (!imu_topic.empty()) {
    rsrio::DdsOptions d;
    d.domain_id = static_cast<int>(domain);
    d.participant_name = kProgram;
    dds = std::make_unique<rsrio::DdsParticipant>(d);
    imu_writer = dds->make_writer(rsrio::ros_topic_to_dds(imu_topic),
                                  eprosima::fastdds::dds::TypeSupport(new sensor_msgs::msg::ImuPubSubType()),
                                  rsrio::QosPreset::kSensorData);
  }
  std::ofstream ground_truth;
  if (!ground_truth_path.empty()) {
    ground_truth.open(ground_truth_path);
    if (!ground_truth) {
      std::cerr << kProgram << ": error: cannot write " << ground_truth_path << "\n";
      g_stop.store(true);
      producer.join();
      return 1;
    }
  }
  std::atomic<std::int64_t> stream_start_ns{0};  // CLOCK_REALTIME when frame 0 was sent
  std::thread imu_thread([&] {
    if (!imu_writer && !ground_truth.is_open()) return;
    while (!g_stop.load() && stream_start_ns.load() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    const std::int64_t w0 = stream_start_ns.load();
    const auto steady0 = std::chrono::steady_clock::now();
    const double t0 = radar.frame_completion(0);
    const double offset = scenario.rig.imu_time_offset_s;
    rsrio::sim::ImuSimulator& imu = sim->imu();
    sensor_msgs::msg::Imu m;
    m.header().frame_id("imu");
    m.orientation().w(0.0);
    m.orientation_covariance()[0] = -1;  // no orientation estimate (sensor_msgs convention)
    while (!g_stop.load() && imu.next_time() <= sim->duration()) {
      const rsrio::sim::ImuSample sample = imu.next();
      const double since = sample.time - t0;  // negative for the samples before frame 0 completes
      std::this_thread::sleep_until(steady0 + std::chrono::nanoseconds(std::llround(std::max(0.0, since) * 1e9)));
      const std::int64_t stamp = w0 + std::llround((since + offset) * 1e9);
      const bool silent = imu_gap_s > 0 && since >= imu_gap_start && since < imu_gap_start + imu_gap_s;
      if (imu_writer && !silent) {
        m.header().stamp().sec(static_cast<std::int32_t>(stamp / 1000000000));
        m.header().stamp().nanosec(static_cast<std::uint32_t>(stamp % 1000000000));
        m.angular_velocity().x(sample.angular_velocity.x());
        m.angular_velocity().y(sample.angular_velocity.y());
        m.angular_velocity().z(sample.angular_velocity.z());
        m.linear_acceleration().x(sample.linear_acceleration.x());
        m.linear_acceleration().y(sample.linear_acceleration.y());
        m.linear_acceleration().z(sample.linear_acceleration.z());
        imu_writer->write(&m);
      }
      if (ground_truth.is_open()) {
        const rsrio::sim::RigState truth = sim->imu_state(sample.time);
        const Eigen::Quaterniond q(truth.rotation);
        ground_truth << std::fixed << std::setprecision(9) << 1e-9 * static_cast<double>(w0 + std::llround(since * 1e9))
                     << ' ' << truth.position.x() << ' ' << truth.position.y() << ' ' << truth.position.z() << ' '
                     << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
      }
    }
  });
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_late = 0;  // the simulator was not ready when the frame was due
  bool was_recording = false;
  auto next_due = std::chrono::steady_clock::now();
  while (!g_stop.load()) {
    const auto now = std::chrono::steady_clock::now();
    const bool recording = emulator->recording();
    auto wait = std::chrono::milliseconds(5);
    if (recording) {
      if (!was_recording) next_due = now;  // the radar starts framing once recording is armed
      if (now >= next_due) {
        std::uint32_t i = 0;
        if (full.try_pop(i)) {
          if (frames_sent == 0)
            stream_start_ns.store(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                      std::chrono::system_clock::now().time_since_epoch())
                                      .count());
          emulator->send_frame(buffers[i]);
          ++frames_sent;
          free_buffers.try_push(i);
          next_due += period;
          if (next_due < std::chrono::steady_clock::now()) {
            ++frames_late;  // sending (or a stall) took longer than a frame period: no burst to catch up
            next_due = std::chrono::steady_clock::now();
          }
        } else {
          wait = std::chrono::milliseconds(1);
        }
      } else {
        wait = std::min(wait, std::chrono::duration_cast<std::chrono::milliseconds>(next_due - now));
      }
    }
    was_recording = recording;
    emulator->serve_commands(wait);
    if (once && frames_sent == scenario_frames) break;
  }
  producer.join();  // with --once it ends by itself after the last frame
  imu_thread.join();
  emulator->flush();

  const auto& c = emulator->counters();
  std::printf(
      "%s: commands=%llu bad_commands=%llu frames_sent=%llu packets_sent=%llu packets_lost=%llu "
      "packets_reordered=%llu packets_duplicated=%llu stalls=%llu frames_late=%llu\n",
      kProgram, static_cast<unsigned long long>(c.commands), static_cast<unsigned long long>(c.bad_commands),
      static_cast<unsigned long long>(c.frames_sent), static_cast<unsigned long long>(c.packets_sent),
      static_cast<unsigned long long>(c.packets_lost), static_cast<unsigned long long>(c.packets_reordered),
      static_cast<unsigned long long>(c.packets_duplicated), static_cast<unsigned long long>(c.stalls),
      static_cast<unsigned long long>(frames_late));
  std::fflush(stdout);
  return 0;
}
