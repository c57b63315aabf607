// DCA1000EVM Ethernet protocol: wire layouts of the config port (4096) commands and responses and
// of the data port (4098) packet header. Facts: TI DCA1000EVM_CLI (rf_api.h, defines.h,
// commandsprotocol.cpp) as summarised in shared/reference/driver_dsp.md Sec. 1; verified against
// the real captures in shared/data/dca1000-pcap/.
//
// Everything on the wire is little-endian. Layouts are built and parsed byte by byte (no struct
// punning), so they are right on any host; the static_asserts pin the sizes TI's code assumes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace rsrio::dca1000 {

inline constexpr std::uint16_t kHeaderMagic = 0xA55A;  // bytes 5A A5 on the wire
inline constexpr std::uint16_t kFooterMagic = 0xEEAA;  // bytes AA EE
inline constexpr std::uint16_t kConfigPort = 4096;
inline constexpr std::uint16_t kDataPort = 4098;
inline constexpr std::size_t kMaxCommandPayload = 504;     // MAX_DATA_BYTES
inline constexpr std::size_t kCommandOverhead = 8;         // header, code, size, footer
inline constexpr std::size_t kResponseSize = 8;            // header, code, status, footer
inline constexpr std::size_t kDataHeaderSize = 10;         // u32 sequence + 48-bit byte count
inline constexpr std::size_t kMaxDataPayload = 1456;       // PAYLOAD_BYTES_PER_PACKET
inline constexpr std::size_t kMaxDatagram = 2048;          // receive buffer per datagram
inline constexpr std::uint16_t kDefaultPacketSize = 1470;  // MAX_BYTES_PER_PACKET (TI defines.h)
inline constexpr double kFpgaClockNs = 8.0;                // packet delay counts 8 ns ticks

static_assert(kCommandOverhead == 2 + 2 + 2 + 2, "command = u16 header, u16 code, u16 size, payload, u16 footer");
static_assert(kResponseSize == 4 * sizeof(std::uint16_t), "response = u16 header, code, status, footer");
static_assert(kDataHeaderSize == sizeof(std::uint32_t) + 6, "data header = u32 sequence, 48-bit byte count");
static_assert(kDataHeaderSize + kMaxDataPayload <= kMaxDatagram, "a data datagram fits the receive buffer");

enum class Command : std::uint16_t {
  kResetFpga = 0x01,
  kResetRadar = 0x02,
  kConfigFpga = 0x03,
  kConfigEeprom = 0x04,
  kStartRecord = 0x05,
  kStopRecord = 0x06,
  kStartPlayback = 0x07,
  kStopPlayback = 0x08,
  kSystemAliveness = 0x09,  // "system connect"
  kAsyncStatus = 0x0A,      // FPGA -> host, status is a bit mask (AsyncStatusBit)
  kConfigPacketData = 0x0B, // packet size and inter-packet delay ("CONFIG_RECORD")
  kConfigRadarDevice = 0x0C,
  kInitFpgaPlayback = 0x0D,
  kReadFpgaVersion = 0x0E,
};
const char* to_string(Command c);

/// Bits of the async status (command 0x0A) mask.
enum AsyncStatusBit : std::uint16_t {
  kNoLvdsData = 1u << 0,
  kNoHeader = 1u << 1,
  kEepromFailure = 1u << 2,
  kSdCardDetected = 1u << 3,
  kSdCardRemoved = 1u << 4,
  kSdCardFull = 1u << 5,
  kModeConfigFailure = 1u << 6,
  kDdrFull = 1u << 7,
  kRecordCompleted = 1u << 8,
  kLvdsBufferFull = 1u << 9,
  kPlaybackCompleted = 1u << 10,
  kPlaybackOutOfSequence = 1u << 11,
};
/// "NO_LVDS_DATA|NO_HEADER" for a mask, for log lines.
std::string describe_async_status(std::uint16_t mask);

/// CONFIG_FPGA payload (6 bytes, order as TI's rf_api.cpp).
struct FpgaConfig {
  std::uint8_t log_mode = 1;       // 1 raw, 2 multi
  std::uint8_t lvds_mode = 2;      // 1 four-lane (xWR1243/1443), 2 two-lane (xWR16xx/18xx/68xx)
  std::uint8_t transfer_mode = 1;  // 1 LVDS capture, 2 playback
  std::uint8_t capture_mode = 2;   // 1 SD card, 2 Ethernet stream
  std::uint8_t format_mode = 3;    // 1 12-bit, 2 14-bit, 3 16-bit
  std::uint8_t lvds_timeout = 30;  // TI CLI default (0x1E)
};

/// CONFIG_PACKET_DATA payload: datagram size and inter-packet delay (5..500 us per SPRUIJ4A).
struct PacketConfig {
  std::uint16_t packet_size = kDefaultPacketSize;
  double delay_us = 25.0;
  std::uint16_t delay_ticks() const;  // delay_us * 1000 / 8 ns
};

/// A command datagram: 5A A5 | code | size | payload | AA EE.
std::vector<std::uint8_t> build_command(Command code, std::span<const std::uint8_t> payload = {});
std::vector<std::uint8_t> build_config_fpga(const FpgaConfig& config);
std::vector<std::uint8_t> build_config_packet_data(const PacketConfig& config);

/// A parsed command (what the board receives; the emulator uses it).
struct CommandView {
  Command code;
  std::span<const std::uint8_t> payload;
};
std::optional<CommandView> parse_command(std::span<const std::uint8_t> datagram);

struct Response {
  Command code;
  std::uint16_t status;  // 0 success, 1 failure; version bits for READ_FPGA_VERSION; mask for async
};
/// 8-byte response; std::nullopt for anything else (wrong size, magic, footer).
std::optional<Response> parse_response(std::span<const std::uint8_t> datagram);
std::array<std::uint8_t, kResponseSize> build_response(Command code, std::uint16_t status);

struct FpgaVersion {
  int major = 0;
  int minor = 0;
  bool playback = false;  // playback bit file loaded instead of record
};
FpgaVersion decode_fpga_version(std::uint16_t status);
std::uint16_t encode_fpga_version(const FpgaVersion& v);

/// Header of a data datagram.
struct DataHeader {
  std::uint32_t sequence = 0;    // 1 for the first packet of a recording, +1 per packet
  std::uint64_t byte_count = 0;  // payload bytes sent before this packet (48 bits on the wire)
};
/// Parses the header of a data datagram; nullopt when it is too short to hold one.
std::optional<DataHeader> parse_data_header(std::span<const std::uint8_t> datagram);
void write_data_header(const DataHeader& h, std::span<std::uint8_t, kDataHeaderSize> out);

}  // namespace rsrio::dca1000
