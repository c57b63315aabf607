#include "rsrio/driver/dca1000_protocol.hpp"

#include <cmath>
#include <stdexcept>

namespace rsrio::dca1000 {

namespace {

inline void put_u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v & 0xFF));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}
inline std::uint16_t get_u16(std::span<const std::uint8_t> b, std::size_t o) {
  return static_cast<std::uint16_t>(b[o] | (b[o + 1] << 8));
}

}  // namespace

const char* to_string(Command c) {
  switch (c) {
    case Command::kResetFpga: return "RESET_FPGA";
    case Command::kResetRadar: return "RESET_AR_DEV";
    case Command::kConfigFpga: return "CONFIG_FPGA";
    case Command::kConfigEeprom: return "CONFIG_EEPROM";
    case Command::kStartRecord: return "START_RECORD";
    case Command::kStopRecord: return "STOP_RECORD";
    case Command::kStartPlayback: return "START_PLAYBACK";
    case Command::kStopPlayback: return "STOP_PLAYBACK";
    case Command::kSystemAliveness: return "SYSTEM_ALIVENESS";
    case Command::kAsyncStatus: return "ASYNC_STATUS";
    case Command::kConfigPacketData: return "CONFIG_PACKET_DATA";
    case Command::kConfigRadarDevice: return "CONFIG_AR_DEV";
    case Command::kInitFpgaPlayback: return "INIT_FPGA_PLAYBACK";
    case Command::kReadFpgaVersion: return "READ_FPGA_VERSION";
  }
  return "UNKNOWN_COMMAND";
}

std::string describe_async_status(std::uint16_t mask) {
  static constexpr const char* kNames[] = {"NO_LVDS_DATA", "NO_HEADER", "EEPROM_FAILURE", "SD_CARD_DETECTED",
                                           "SD_CARD_REMOVED", "SD_CARD_FULL", "MODE_CONFIG_FAILURE", "DDR_FULL",
                                           "REC_COMPLETED", "LVDS_BUFFER_FULL", "PLAYBACK_COMPLETED",
                                           "PLAYBACK_OUT_OF_SEQ"};
  std::string s;
  for (int bit = 0; bit < 16; ++bit) {
    if (!(mask & (1u << bit))) continue;
    if (!s.empty()) s += "|";
    s += bit < 12 ? kNames[bit] : "BIT" + std::to_string(bit);
  }
  return s.empty() ? "none" : s;
}

std::uint16_t PacketConfig::delay_ticks() const {
  return static_cast<std::uint16_t>(std::lround(delay_us * 1000.0 / kFpgaClockNs));
}

std::vector<std::uint8_t> build_command(Command code, std::span<const std::uint8_t> payload) {
  if (payload.size() > kMaxCommandPayload)
    throw std::invalid_argument("DCA1000 command payload over 504 bytes");
  std::vector<std::uint8_t> out;
  out.reserve(kCommandOverhead + payload.size());
  put_u16(out, kHeaderMagic);
  put_u16(out, static_cast<std::uint16_t>(code));
  put_u16(out, static_cast<std::uint16_t>(payload.size()));
  out.insert(out.end(), payload.begin(), payload.end());
  put_u16(out, kFooterMagic);
  return out;
}

std::vector<std::uint8_t> build_config_fpga(const FpgaConfig& c) {
  const std::array<std::uint8_t, 6> p{c.log_mode, c.lvds_mode, c.transfer_mode, c.capture_mode, c.format_mode,
                                      c.lvds_timeout};
  return build_command(Command::kConfigFpga, p);
}

std::vector<std::uint8_t> build_config_packet_data(const PacketConfig& c) {
  std::vector<std::uint8_t> p;
  put_u16(p, c.packet_size);
  put_u16(p, c.delay_ticks());
  put_u16(p, 0);
  return build_command(Command::kConfigPacketData, p);
}

std::optional<CommandView> parse_command(std::span<const std::uint8_t> d) {
  if (d.size() < kCommandOverhead) return std::nullopt;
  if (get_u16(d, 0) != kHeaderMagic) return std::nullopt;
  const std::size_t size = get_u16(d, 4);
  if (size > kMaxCommandPayload || d.size() != kCommandOverhead + size) return std::nullopt;
  if (get_u16(d, 6 + size) != kFooterMagic) return std::nullopt;
  return CommandView{static_cast<Command>(get_u16(d, 2)), d.subspan(6, size)};
}

std::optional<Response> parse_response(std::span<const std::uint8_t> d) {
  if (d.size() != kResponseSize) return std::nullopt;
  if (get_u16(d, 0) != kHeaderMagic || get_u16(d, 6) != kFooterMagic) return std::nullopt;
  return Response{static_cast<Command>(get_u16(d, 2)), get_u16(d, 4)};
}

std::array<std::uint8_t, kResponseSize> build_response(Command code, std::uint16_t status) {
  const auto c = static_cast<std::uint16_t>(code);
  return {0x5A, 0xA5, static_cast<std::uint8_t>(c & 0xFF), static_cast<std::uint8_t>(c >> 8),
          static_cast<std::uint8_t>(status & 0xFF), static_cast<std::uint8_t>(status >> 8), 0xAA, 0xEE};
}

FpgaVersion decode_fpga_version(std::uint16_t s) {
  return {s & 0x7F, (s >> 7) & 0x7F, (s & 0x4000) != 0};
}

std::uint16_t encode_fpga_version(const FpgaVersion& v) {
  return static_cast<std::uint16_t>((v.major & 0x7F) | ((v.minor & 0x7F) << 7) | (v.playback ? 0x4000 : 0));
}

std::optional<DataHeader> parse_data_header(std::span<const std::uint8_t> d) {
  if (d.size() < kDataHeaderSize) return std::nullopt;
  DataHeader h;
  h.sequence = std::uint32_t(d[0]) | std::uint32_t(d[1]) << 8 | std::uint32_t(d[2]) << 16 | std::uint32_t(d[3]) << 24;
  for (int i = 0; i < 6; ++i) h.byte_count |= std::uint64_t(d[4 + i]) << (8 * i);
  return h;
}

void write_data_header(const DataHeader& h, std::span<std::uint8_t, kDataHeaderSize> out) {
  for (int i = 0; i < 4; ++i) out[i] = static_cast<std::uint8_t>(h.sequence >> (8 * i));
  for (int i = 0; i < 6; ++i) out[4 + i] = static_cast<std::uint8_t>(h.byte_count >> (8 * i));
}

}  // namespace rsrio::dca1000
