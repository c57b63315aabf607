// Sustained receive throughput and CPU per frame of the DCA1000 driver (recvmmsg batches, frame
// assembly, hand-out and release) against the board emulator over loopback UDP, beside the
// DCA1000's line rate (1 Gb/s Ethernet: 125 MB/s on the wire, 118.8 MB/s of ADC payload in
// 1456-byte packets with their 10-byte header, UDP/IP/Ethernet framing, preamble and gap).
//
// Two runs per frame size: the emulator paced at the line rate (what a real board can send: the
// driver must keep up with every frame good, and the CPU share says how much room is left), and
// flat out (the emulator sends as fast as loopback takes it; the kernel drops what the receiver
// cannot take in time, which the socket reports). CPU is the receive thread's own CPU time
// (CLOCK_THREAD_CPUTIME_ID), so the emulator's sending does not count.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <random>
#include <thread>
#include <vector>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/driver/dca1000_driver.hpp"
#include "rsrio/driver/dca1000_emulator.hpp"

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr double kLineRateBytesPerS = 1e9 / 8;  // 1 Gb/s
// Payload share of the wire: 1456 payload of 10 header + 1456 + UDP 8 + IP 20 + Ethernet 14 + FCS 4
// + preamble 8 + inter-frame gap 12.
constexpr double kPayloadShare = 1456.0 / (10 + 1456 + 8 + 20 + 14 + 4 + 8 + 12);
constexpr double kLinePayloadBytesPerS = kLineRateBytesPerS * kPayloadShare;

double thread_cpu_s() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

struct Result {
  std::size_t frames_sent = 0, good = 0, damaged = 0;
  std::uint64_t kernel_drops = 0, lost_packets = 0;
  double seconds = 0, cpu_s = 0;
  int receive_buffer = 0;
};

Result run(std::size_t frame_bytes, std::size_t n_frames, bool paced) {
  rsrio::EmulatorOptions eo;
  eo.board = {0x7F000002u, 0};
  rsrio::Dca1000Emulator emulator(eo);
  rsrio::Dca1000Options o;
  o.board = emulator.config_endpoint();
  o.host_config = {0x7F000001u, 0};
  o.host_data = {0x7F000001u, 0};
  o.command_timeout = 500ms;
  rsrio::Dca1000Driver driver(o, frame_bytes);
  emulator.set_host_data(driver.data_socket().local());

  std::vector<std::uint8_t> frame(frame_bytes);
  std::mt19937 rng(1);
  for (auto& b : frame) b = static_cast<std::uint8_t>(rng());
  std::atomic<bool> stop{false};
  std::thread board([&] {
    std::size_t sent = 0;
    Clock::time_point start{};
    while (!stop) {
      emulator.serve_commands(sent < n_frames && emulator.recording() ? 0ms : 2ms);
      if (!emulator.recording() || sent >= n_frames) continue;
      if (sent == 0) start = Clock::now();
      emulator.send_frame(frame);
      ++sent;
      if (paced)
        std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                                                  double(sent * frame_bytes) / kLinePayloadBytesPerS)));
    }
  });

  Result r;
  r.frames_sent = n_frames;
  r.receive_buffer = driver.data_socket().receive_buffer_bytes();
  driver.start();
  const double cpu0 = thread_cpu_s();
  const auto t0 = Clock::now();
  auto last_frame = t0, quiet_since = t0;
  while (r.good + r.damaged < n_frames && Clock::now() - quiet_since < 500ms) {
    if (driver.poll(20ms) > 0) quiet_since = Clock::now();
    while (auto* f = driver.next_frame()) {
      ((f->flags & rsrio::kFrameDamaged) ? r.damaged : r.good) += 1;
      last_frame = Clock::now();
      driver.release(f);
    }
  }
  r.cpu_s = thread_cpu_s() - cpu0;
  r.seconds = std::chrono::duration<double>(last_frame - t0).count();
  driver.stop();
  while (auto* f = driver.next_frame()) {
    ((f->flags & rsrio::kFrameDamaged) ? r.damaged : r.good) += 1;
    driver.release(f);
  }
  stop = true;
  board.join();
  r.kernel_drops = driver.counters().kernel_drops;
  r.lost_packets = driver.assembler_counters().lost_packets;
  return r;
}

}  // namespace

int main() {
  struct Case {
    const char* name;
    std::size_t frame_bytes;
    std::size_t frames;
  };
  const std::size_t xwr1843 = rsrio::dca1000_frame_bytes(rsrio::radar_preset("xwr1843"));
  const Case cases[] = {{"xwr1843 preset", xwr1843, 300}, {"64 KiB frames", 65536, 3000}};

  std::printf("DCA1000 driver receive vs emulator on loopback UDP (line rate 1 Gb/s = %.1f MB/s of ADC payload)\n",
              kLinePayloadBytesPerS / 1e6);
  std::printf("%-16s %-9s %10s %6s %6s %8s %9s %8s %7s %10s %9s %12s %8s\n", "frames", "sender", "frame B", "sent",
              "good", "damaged", "kern.drop", "MB/s", "x line", "CPU us/fr", "CPU %core", "MB/CPU-s", "x line");
  int receive_buffer = 0;
  for (const Case& c : cases) {
    for (bool paced : {true, false}) {
      const Result r = run(c.frame_bytes, c.frames, paced);
      receive_buffer = r.receive_buffer;
      const std::size_t got = r.good + r.damaged;
      const double mbps = r.seconds > 0 ? double(got * c.frame_bytes) / r.seconds / 1e6 : 0;
      // What the receive thread could take if it had a core to itself: bytes per second of its CPU.
      const double capacity = r.cpu_s > 0 ? double(got * c.frame_bytes) / r.cpu_s / 1e6 : 0;
      std::printf("%-16s %-9s %10zu %6zu %6zu %8zu %9llu %8.1f %7.2f %10.1f %9.1f %12.0f %8.1f\n", c.name,
                  paced ? "1 Gb/s" : "flat out", c.frame_bytes, r.frames_sent, r.good, r.damaged,
                  static_cast<unsigned long long>(r.kernel_drops), mbps, mbps * 1e6 / kLinePayloadBytesPerS,
                  got ? 1e6 * r.cpu_s / double(got) : 0.0, r.seconds > 0 ? 100.0 * r.cpu_s / r.seconds : 0.0, capacity,
                  capacity * 1e6 / kLinePayloadBytesPerS);
    }
  }
  std::printf("(socket receive buffer granted: %d bytes. MB/s: received frames, good or damaged, per second of\n"
              " wall time, bounded by the emulator's sending on the same machine; MB/CPU-s: per second of the\n"
              " receive thread's own CPU time, what the driver sustains with a core to itself)\n",
              receive_buffer);
  return 0;
}
