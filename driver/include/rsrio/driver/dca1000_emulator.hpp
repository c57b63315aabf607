// A DCA1000EVM on loopback: answers the command protocol as the board does and streams frames
// as data packets (sequence number, byte count, 1456-byte payloads), with injected faults, so
// the live path is tested end to end without hardware.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <random>
#include <span>
#include <vector>

#include "rsrio/driver/dca1000_protocol.hpp"
#include "rsrio/driver/udp_socket.hpp"

namespace rsrio {

struct EmulatorFaults {
  double loss = 0;       // probability a packet is never sent
  double reorder = 0;    // probability a packet is held back and sent 1-8 packets later
  double duplicate = 0;  // probability a packet is sent twice
  int stall_ms = 0;      // pause the stream this long ...
  int stall_every_frames = 50;  // ... after every this many frames
  std::uint64_t seed = 1;
};

struct EmulatorOptions {
  Endpoint board{0x7F000002u, dca1000::kConfigPort};  // 127.0.0.2:4096: the "board" on loopback
  Endpoint host_data{0x7F000001u, dca1000::kDataPort};  // where the data goes (127.0.0.1:4098)
  std::size_t payload_bytes = dca1000::kMaxDataPayload;
  dca1000::FpgaVersion version{2, 8, false};          // what the real board in test_cmd.pcap reports
  EmulatorFaults faults;
  bool refuse_commands = false;  // answer every command with failure status 1 (error tests)
};

struct EmulatorCounters {
  std::uint64_t commands = 0;
  std::uint64_t bad_commands = 0;
  std::uint64_t frames_sent = 0;
  std::uint64_t packets_sent = 0;     // datagrams actually sent, duplicates included
  std::uint64_t packets_lost = 0;     // dropped by the loss fault
  std::uint64_t packets_reordered = 0;
  std::uint64_t packets_duplicated = 0;
  std::uint64_t stalls = 0;
};

class Dca1000Emulator {
 public:
  explicit Dca1000Emulator(const EmulatorOptions& options);

  /// Answers the commands that arrived within `timeout`. Returns how many were handled.
  int serve_commands(std::chrono::milliseconds timeout);
  /// True between START_RECORD and STOP_RECORD.
  bool recording() const { return recording_; }
  /// Streams one frame (continuing sequence numbers and byte count), applying the faults.
  void send_frame(std::span<const std::uint8_t> frame);
  /// Sends what the reorder fault still holds back (end of stream).
  void flush();

  const Endpoint& config_endpoint() const { return config_endpoint_; }
  /// Where the data goes (a real board has it in its EEPROM; tests learn the driver's port late).
  void set_host_data(const Endpoint& e) { options_.host_data = e; }
  const EmulatorCounters& counters() const { return counters_; }

 private:
  void send_packet(std::uint32_t sequence, std::uint64_t byte_count, std::span<const std::uint8_t> payload);
  void transmit(const std::vector<std::uint8_t>& datagram);

  EmulatorOptions options_;
  UdpSocket config_;
  UdpSocket data_;
  Endpoint config_endpoint_;
  Endpoint host_config_{};  // who talks to us (replies go there)
  bool recording_ = false;
  std::uint32_t sequence_ = 0;
  std::uint64_t byte_count_ = 0;
  std::mt19937_64 rng_;
  struct Held {
    std::vector<std::uint8_t> datagram;
    int release_after;  // packets still to send before this one
  };
  std::deque<Held> held_;
  std::vector<std::uint8_t> scratch_;
  EmulatorCounters counters_;
};

}  // namespace rsrio
