#include "rsrio/driver/dca1000_emulator.hpp"

#include <algorithm>
#include <array>
#include <thread>

namespace rsrio {

using dca1000::Command;

Dca1000Emulator::Dca1000Emulator(const EmulatorOptions& options)
    : options_(options),
      config_(options.board),
      data_(Endpoint{options.board.ip, 0}),
      config_endpoint_(config_.local()),
      rng_(options.faults.seed) {}

int Dca1000Emulator::serve_commands(std::chrono::milliseconds timeout) {
  std::array<std::uint8_t, 1024> buffer{};
  int handled = 0;
  Endpoint from;
  long n = config_.receive(buffer, from, timeout);
  while (n > 0) {
    const auto cmd = dca1000::parse_command(std::span(buffer.data(), static_cast<std::size_t>(n)));
    if (!cmd) {
      ++counters_.bad_commands;  // the real board ignores what it cannot parse
    } else {
      ++counters_.commands;
      ++handled;
      host_config_ = from;
      std::uint16_t status = options_.refuse_commands ? 1 : 0;
      switch (cmd->code) {
        case Command::kReadFpgaVersion:
          status = dca1000::encode_fpga_version(options_.version);
          break;
        case Command::kStartRecord:
          if (!options_.refuse_commands) {
            recording_ = true;
            sequence_ = 0;
            byte_count_ = 0;
          }
          break;
        case Command::kStopRecord:
          recording_ = false;
          break;
        case Command::kConfigFpga:
          if (cmd->payload.size() != 6) status = 1;
          break;
        case Command::kConfigPacketData:
          if (cmd->payload.size() != 6) status = 1;
          break;
        default:
          break;
      }
      if (cmd->code == Command::kStopRecord) flush();  // the board holds nothing back: all out before the answer
      const auto response = dca1000::build_response(cmd->code, status);
      config_.send_to(from, response);
      if (cmd->code == Command::kStopRecord && !options_.refuse_commands) {
        // As the real board does after a recording (last datagram of test_one_frame.pcap).
        const auto done = dca1000::build_response(Command::kAsyncStatus, dca1000::kRecordCompleted);
        config_.send_to(from, done);
      }
    }
    n = config_.receive(buffer, from, std::chrono::milliseconds(0));
  }
  return handled;
}

void Dca1000Emulator::transmit(const std::vector<std::uint8_t>& datagram) {
  data_.send_to(options_.host_data, datagram);
  ++counters_.packets_sent;
  // Held-back packets go out once enough later packets have passed them.
  for (auto it = held_.begin(); it != held_.end();) {
    if (--it->release_after <= 0) {
      data_.send_to(options_.host_data, it->datagram);
      ++counters_.packets_sent;
      it = held_.erase(it);
    } else {
      ++it;
    }
  }
}

void Dca1000Emulator::send_packet(std::uint32_t sequence, std::uint64_t byte_count,
                                  std::span<const std::uint8_t> payload) {
  const auto& f = options_.faults;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // Draw every fault for every packet so that the fault pattern depends only on the seed.
  const bool lose = u(rng_) < f.loss;
  const bool reorder = u(rng_) < f.reorder;
  const bool duplicate = u(rng_) < f.duplicate;
  const int hold = std::uniform_int_distribution<int>(1, 8)(rng_);
  if (lose) {
    ++counters_.packets_lost;
    return;
  }
  std::vector<std::uint8_t> d(dca1000::kDataHeaderSize + payload.size());
  dca1000::write_data_header({sequence, byte_count}, std::span<std::uint8_t, dca1000::kDataHeaderSize>(d.data(), 10));
  std::copy(payload.begin(), payload.end(), d.begin() + dca1000::kDataHeaderSize);
  if (reorder) {
    ++counters_.packets_reordered;
    if (duplicate) ++counters_.packets_duplicated;
    held_.push_back({d, hold});
    if (duplicate) held_.push_back({std::move(d), hold});
    return;
  }
  transmit(d);
  if (duplicate) {
    ++counters_.packets_duplicated;
    transmit(d);
  }
}

void Dca1000Emulator::send_frame(std::span<const std::uint8_t> frame) {
  std::size_t pos = 0;
  while (pos < frame.size()) {
    const std::size_t n = std::min(options_.payload_bytes, frame.size() - pos);
    send_packet(++sequence_, byte_count_, frame.subspan(pos, n));
    byte_count_ += n;
    pos += n;
  }
  ++counters_.frames_sent;
  const auto& f = options_.faults;
  if (f.stall_ms > 0 && f.stall_every_frames > 0 && counters_.frames_sent % f.stall_every_frames == 0) {
    ++counters_.stalls;
    std::this_thread::sleep_for(std::chrono::milliseconds(f.stall_ms));
  }
}

void Dca1000Emulator::flush() {
  for (auto& h : held_) {
    data_.send_to(options_.host_data, h.datagram);
    ++counters_.packets_sent;
  }
  held_.clear();
}

}  // namespace rsrio
