// The DCA1000EVM capture driver: commands on the config port, the raw stream on the data port.
//
// Shaped like a PX4 sensor driver: an explicit state machine, a counter for every failure mode,
// wire layouts pinned in dca1000_protocol.hpp, and no allocation once streaming (datagrams land
// in a preallocated batch, frames in the FrameAssembler's preallocated pool).
//
//   kIdle --start()--> kConnecting --(aliveness, version)--> kConfiguring --(FPGA, packets)-->
//   kStarting --(START_RECORD)--> kStreaming --stop()--> kStopped;   any failure --> kError
#pragma once

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "rsrio/driver/dca1000_protocol.hpp"
#include "rsrio/driver/frame_assembler.hpp"
#include "rsrio/driver/udp_socket.hpp"

namespace rsrio {

struct Dca1000Options {
  Endpoint board{0xC0A821B4u, dca1000::kConfigPort};        // 192.168.33.180:4096 (TI default)
  Endpoint host_config{0xC0A8211Eu, dca1000::kConfigPort};  // 192.168.33.30:4096, this host
  Endpoint host_data{0xC0A8211Eu, dca1000::kDataPort};      // 192.168.33.30:4098
  dca1000::FpgaConfig fpga;                                 // raw, 2 lanes, Ethernet, 16 bit
  dca1000::PacketConfig packets;                            // 1470-byte packets, 25 us delay
  std::chrono::milliseconds command_timeout{1000};
  int command_retries = 3;
  int receive_buffer_bytes = 16 << 20;    // several frames; raise net.core.rmem_max to get it
  std::size_t pool_frames = 6;            // raised to what the reorder window and batch need (small frames)
  std::size_t batch_datagrams = 64;
  std::chrono::milliseconds stale_frame{250};  // an incomplete frame with no packets this long is closed
};

enum class DriverState { kIdle, kConnecting, kConfiguring, kStarting, kStreaming, kStopping, kStopped, kError };
const char* to_string(DriverState s);

struct DriverCounters {
  std::uint64_t commands_sent = 0;
  std::uint64_t command_retries = 0;
  std::uint64_t command_timeouts = 0;
  std::uint64_t command_failures = 0;   // the board answered with a failure status
  std::uint64_t bad_responses = 0;      // config-port datagrams that are not valid responses
  std::uint64_t unexpected_responses = 0;
  std::uint64_t async_events = 0;
  std::uint16_t last_async_mask = 0;
  std::uint64_t foreign_datagrams = 0;  // from an address that is not the board: ignored
  std::uint64_t truncated_datagrams = 0;
  std::uint64_t receive_errors = 0;
  std::uint64_t kernel_drops = 0;       // data datagrams the kernel dropped: this host fell behind
};

/// A command the board did not answer, or refused. The message says what to check.
class Dca1000Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Dca1000Driver {
 public:
  /// Binds both host sockets. Throws std::system_error naming the address (already in use? not
  /// this host's address?).
  Dca1000Driver(const Dca1000Options& options, std::size_t frame_bytes);

  /// Connects, reads the FPGA version, configures FPGA and packets, starts recording.
  /// Throws Dca1000Error (state kError). Start the radar only after this returns.
  dca1000::FpgaVersion start();
  /// STOP_RECORD; closes the open frames. Never throws (a board that is gone is counted).
  void stop();
  /// Sends one command and waits for its response (with retries); returns the status.
  std::uint16_t command(dca1000::Command code, std::span<const std::uint8_t> payload = {});

  /// Receives what arrives within `timeout` (one batch) and assembles it; also closes frames
  /// that went stale. Returns the number of data datagrams handled. Real-time safe.
  int poll(std::chrono::milliseconds timeout);
  /// Answers and counts what arrived on the config port (async status) without waiting.
  void poll_config();

  AssembledFrame* next_frame() { return assembler_.next_ready(); }
  void release(AssembledFrame* f) { assembler_.release(f); }

  DriverState state() const { return state_; }
  const DriverCounters& counters() const { return counters_; }
  const AssemblerCounters& assembler_counters() const { return assembler_.counters(); }
  const UdpSocket& data_socket() const { return data_; }
  const UdpSocket& config_socket() const { return config_; }
  /// CLOCK_REALTIME - CLOCK_MONOTONIC in ns, sampled at start(): frame stamps map to wall time.
  std::int64_t realtime_offset_ns() const { return realtime_offset_ns_; }

 private:
  bool handle_config_datagram(std::span<const std::uint8_t> d, const Endpoint& from, dca1000::Command waiting_for,
                              std::uint16_t& status);

  Dca1000Options options_;
  UdpSocket config_;
  UdpSocket data_;
  DatagramBatch batch_;
  FrameAssembler assembler_;
  DriverState state_ = DriverState::kIdle;
  DriverCounters counters_;
  std::int64_t realtime_offset_ns_ = 0;
};

/// CLOCK_MONOTONIC now, in ns.
std::int64_t monotonic_ns();
/// CLOCK_REALTIME - CLOCK_MONOTONIC, in ns (sampled as a tight pair).
std::int64_t realtime_minus_monotonic_ns();

}  // namespace rsrio
