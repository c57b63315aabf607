#include "rsrio/driver/dca1000_driver.hpp"

#include <algorithm>
#include <array>
#include <ctime>
#include <thread>

namespace rsrio {

using dca1000::Command;

std::int64_t monotonic_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::int64_t realtime_minus_monotonic_ns() {
  // Bracket the realtime read by two monotonic reads and take their midpoint.
  timespec a{}, r{}, b{};
  ::clock_gettime(CLOCK_MONOTONIC, &a);
  ::clock_gettime(CLOCK_REALTIME, &r);
  ::clock_gettime(CLOCK_MONOTONIC, &b);
  const std::int64_t ma = std::int64_t(a.tv_sec) * 1'000'000'000 + a.tv_nsec;
  const std::int64_t mb = std::int64_t(b.tv_sec) * 1'000'000'000 + b.tv_nsec;
  const std::int64_t rr = std::int64_t(r.tv_sec) * 1'000'000'000 + r.tv_nsec;
  return rr - (ma + (mb - ma) / 2);
}

const char* to_string(DriverState s) {
  switch (s) {
    case DriverState::kIdle: return "idle";
    case DriverState::kConnecting: return "connecting";
    case DriverState::kConfiguring: return "configuring";
    case DriverState::kStarting: return "starting";
    case DriverState::kStreaming: return "streaming";
    case DriverState::kStopping: return "stopping";
    case DriverState::kStopped: return "stopped";
    case DriverState::kError: return "error";
  }
  return "?";
}

Dca1000Driver::Dca1000Driver(const Dca1000Options& options, std::size_t frame_bytes)
    : options_(options),
      config_(options.host_config),
      data_(options.host_data, options.receive_buffer_bytes),
      batch_(options.batch_datagrams, dca1000::kMaxDatagram),
      assembler_(frame_bytes,
                 std::max(options.pool_frames,
                          FrameAssembler::pool_frames_needed(frame_bytes, kDefaultReorderWindowBytes,
                                                             options.batch_datagrams * dca1000::kMaxDataPayload))) {}

bool Dca1000Driver::handle_config_datagram(std::span<const std::uint8_t> d, const Endpoint& from,
                                           Command waiting_for, std::uint16_t& status) {
  if (from.ip != options_.board.ip) {
    ++counters_.foreign_datagrams;
    return false;
  }
  const auto r = dca1000::parse_response(d);
  if (!r) {
    ++counters_.bad_responses;
    return false;
  }
  if (r->code == Command::kAsyncStatus) {
    ++counters_.async_events;
    counters_.last_async_mask = r->status;
    if (waiting_for != Command::kAsyncStatus) return false;
  }
  if (r->code != waiting_for) {
    ++counters_.unexpected_responses;
    return false;
  }
  status = r->status;
  return true;
}

std::uint16_t Dca1000Driver::command(Command code, std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> datagram;
  if (code == Command::kConfigFpga && payload.empty()) {
    datagram = dca1000::build_config_fpga(options_.fpga);
  } else if (code == Command::kConfigPacketData && payload.empty()) {
    datagram = dca1000::build_config_packet_data(options_.packets);
  } else {
    datagram = dca1000::build_command(code, payload);
  }
  std::array<std::uint8_t, 512> buffer{};
  for (int attempt = 0; attempt <= options_.command_retries; ++attempt) {
    if (attempt > 0) ++counters_.command_retries;
    ++counters_.commands_sent;
    if (!config_.send_to(options_.board, datagram)) {
      ++counters_.receive_errors;
      continue;
    }
    const auto deadline = std::chrono::steady_clock::now() + options_.command_timeout;
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) break;
      Endpoint from;
      const long n = config_.receive(buffer, from, left);
      if (n <= 0) {
        if (n < 0) ++counters_.receive_errors;
        continue;
      }
      std::uint16_t status = 0;
      if (handle_config_datagram(std::span(buffer.data(), static_cast<std::size_t>(n)), from, code, status)) {
        if (status != 0 && code != Command::kReadFpgaVersion) {
          ++counters_.command_failures;
          state_ = DriverState::kError;
          throw Dca1000Error(std::string("DCA1000 at ") + options_.board.to_string() + " refused " +
                             dca1000::to_string(code) + " (status " + std::to_string(status) + ")");
        }
        return status;
      }
    }
    ++counters_.command_timeouts;
  }
  state_ = DriverState::kError;
  throw Dca1000Error(std::string("DCA1000 at ") + options_.board.to_string() + " did not answer " +
                     dca1000::to_string(code) + " after " + std::to_string(options_.command_retries + 1) +
                     " tries: is it powered and cabled, and does this host own " +
                     options_.host_config.ip_string() + " on that interface?");
}

dca1000::FpgaVersion Dca1000Driver::start() {
  state_ = DriverState::kConnecting;
  command(Command::kSystemAliveness);
  const auto version = dca1000::decode_fpga_version(command(Command::kReadFpgaVersion));
  state_ = DriverState::kConfiguring;
  command(Command::kConfigFpga);
  // The FPGA ignores requests for a moment after CONFIG_FPGA (RadarML/xwr): knock until it answers.
  command(Command::kSystemAliveness);
  command(Command::kConfigPacketData);
  state_ = DriverState::kStarting;
  realtime_offset_ns_ = realtime_minus_monotonic_ns();
  command(Command::kStartRecord);
  state_ = DriverState::kStreaming;
  return version;
}

void Dca1000Driver::stop() {
  if (state_ == DriverState::kStreaming || state_ == DriverState::kStarting) {
    state_ = DriverState::kStopping;
    try {
      command(Command::kStopRecord);
    } catch (const Dca1000Error&) {
      // counted in command(); the board may be gone (unplugged): stopping still succeeds here
    }
    // The board sent everything before it answered STOP_RECORD: take what is still queued on the
    // data socket before closing the open frames, or the last frame would be cut for nothing.
    // (Bounded: a flood from elsewhere cannot keep stop() here.)
    for (int batches = 0; batches < 4096 && poll(std::chrono::milliseconds(0)) > 0; ++batches) {
    }
  }
  assembler_.flush_all(monotonic_ns());
  state_ = DriverState::kStopped;
}

void Dca1000Driver::poll_config() {
  std::array<std::uint8_t, 512> buffer{};
  Endpoint from;
  long n;
  while ((n = config_.receive(buffer, from, std::chrono::milliseconds(0))) > 0) {
    std::uint16_t status = 0;
    handle_config_datagram(std::span(buffer.data(), static_cast<std::size_t>(n)), from, Command::kAsyncStatus, status);
  }
}

int Dca1000Driver::poll(std::chrono::milliseconds timeout) {
  const int n = batch_.receive(data_, timeout);
  const std::int64_t now = monotonic_ns();
  if (n < 0) ++counters_.receive_errors;
  counters_.kernel_drops = batch_.kernel_drops();
  int handled = 0;
  for (int i = 0; i < n; ++i) {
    if (batch_.source(i).ip != options_.board.ip) {
      ++counters_.foreign_datagrams;
      continue;
    }
    if (batch_.truncated(i)) {
      ++counters_.truncated_datagrams;
      continue;
    }
    assembler_.on_datagram(batch_.datagram(i), now);
    ++handled;
  }
  assembler_.flush_stale(now, std::chrono::duration_cast<std::chrono::nanoseconds>(options_.stale_frame).count());
  return handled;
}

}  // namespace rsrio
