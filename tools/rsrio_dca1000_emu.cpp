// rsrio-dca1000-emu: a DCA1000EVM on loopback. Answers the board's command protocol on ADDR
// (default 127.0.0.2:4096, the Dca1000Emulator) and, while recording, streams the simulator's raw
// ADC of a scenario at its frame rate to the host's data port, with injected packet faults.
// The DCA1000 carries one xWR1843, so mmwcas scenarios are refused. The scenario repeats until
// stopped (frame numbers go on). SIGINT / SIGTERM stop it; the counters are printed on exit.
// Exit 0 on a clean stop, 2 for a bad command line or scenario, 1 when the socket cannot be bound.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
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
#include "rsrio/sim/simulation.hpp"

namespace {

constexpr const char* kProgram = "rsrio-dca1000-emu";

std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
extern "C" void on_signal(int) { g_stop.store(true); }

int usage_error(const std::string& message) {
  std::cerr << kProgram << ": error: " << message << "\n(see " << kProgram << " --help)\n";
  return rsrio::kExitUsage;
}

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
                             host_data_text = "127.0.0.1:4098", threads_text = "2";
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
  if (auto rc = cli.parse(argc, argv)) return *rc;
  if (auto rc = rsrio::load_program_config(cli, kProgram, [](rsrio::OptionsNode&) {})) return *rc;

  if (scenario_path.empty()) return usage_error("--scenario FILE is required");
  rsrio::EmulatorOptions options;
  auto& f = options.faults;
  if (!parse_probability(loss_text, f.loss)) return usage_error("--loss: expected a probability in [0, 1], got '" + loss_text + "'");
  if (!parse_probability(reorder_text, f.reorder))
    return usage_error("--reorder: expected a probability in [0, 1], got '" + reorder_text + "'");
  if (!parse_probability(duplicate_text, f.duplicate))
    return usage_error("--duplicate: expected a probability in [0, 1], got '" + duplicate_text + "'");
  std::uint64_t stall = 0, stall_every = 0, threads = 0;
  if (!parse_u64(stall_text, stall) || stall > 60000)
    return usage_error("--stall: expected milliseconds in [0, 60000], got '" + stall_text + "'");
  if (!parse_u64(stall_every_text, stall_every) || stall_every < 1 || stall_every > 1000000)
    return usage_error("--stall-every: expected a number of frames >= 1, got '" + stall_every_text + "'");
  if (!parse_u64(seed_text, f.seed)) return usage_error("--seed: expected a non-negative integer, got '" + seed_text + "'");
  if (!parse_u64(threads_text, threads) || threads < 1 || threads > 64)
    return usage_error("--threads: expected an integer in [1, 64], got '" + threads_text + "'");
  f.stall_ms = static_cast<int>(stall);
  f.stall_every_frames = static_cast<int>(stall_every);
  try {
    options.board = rsrio::Endpoint::parse(address_text, rsrio::dca1000::kConfigPort);
    options.host_data = rsrio::Endpoint::parse(host_data_text, rsrio::dca1000::kDataPort);
  } catch (const std::invalid_argument& e) {
    return usage_error(std::string("--address/--host-data: ") + e.what());
  }

  rsrio::sim::Scenario scenario;
  try {
    scenario = rsrio::sim::load_scenario(scenario_path);
  } catch (const rsrio::ConfigError& e) {
    std::cerr << kProgram << ": error: " << e.what() << "\n";
    return rsrio::kExitUsage;
  }
  if (scenario.radar.capture.format != "dca1000")
    return usage_error(scenario_path + ": its radar is the '" + scenario.radar.preset +
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
  if (scenario_frames == 0) return usage_error(scenario_path + ": the scenario completes no radar frame");
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
    while (!g_stop.load()) {
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
          emulator->send_frame(buffers[i]);
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
  }
  producer.join();
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
