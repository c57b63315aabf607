// The DCA1000 wire formats against the real captures and TI's documented command bytes.
#include "rsrio/driver/dca1000_protocol.hpp"

#include <catch2/catch_test_macros.hpp>

#include "test_pcap.hpp"

using namespace rsrio::dca1000;

namespace {
std::vector<std::uint8_t> hex(const std::string& s) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < s.size(); i += 2) out.push_back(static_cast<std::uint8_t>(std::stoi(s.substr(i, 2), nullptr, 16)));
  return out;
}
}  // namespace

TEST_CASE("commands are the bytes TI's CLI and OpenRadar send", "[dca1000]") {
  CHECK(build_command(Command::kSystemAliveness) == hex("5aa509000000aaee"));
  CHECK(build_command(Command::kReadFpgaVersion) == hex("5aa50e000000aaee"));
  CHECK(build_command(Command::kStartRecord) == hex("5aa505000000aaee"));
  CHECK(build_command(Command::kStopRecord) == hex("5aa506000000aaee"));
  FpgaConfig two_lane;  // raw, 2-lane, capture, Ethernet, 16-bit, timeout 30 (xWR18xx)
  CHECK(build_config_fpga(two_lane) == hex("5aa50300060001020102031eaaee"));
  FpgaConfig four_lane;
  four_lane.lvds_mode = 1;
  CHECK(build_config_fpga(four_lane) == hex("5aa50300060001010102031eaaee"));
  PacketConfig packets;  // 1472-byte packets, 25 us -> 3125 ticks of 8 ns
  packets.packet_size = 1472;
  CHECK(packets.delay_ticks() == 3125);
  CHECK(build_config_packet_data(packets) == hex("5aa50b000600c005350c0000aaee"));
  const auto parsed = parse_command(build_config_fpga(two_lane));
  REQUIRE(parsed);
  CHECK(parsed->code == Command::kConfigFpga);
  CHECK(parsed->payload.size() == 6);
  CHECK_FALSE(parse_command(hex("5aa509000100aaee")));  // size says 1, no payload
  CHECK_FALSE(parse_command(hex("5aa5090000")));
}

TEST_CASE("the real command exchange parses, and our responses are its bytes", "[dca1000]") {
  const auto datagrams = rsrio::test::read_pcap_udp("../shared/data/dca1000-pcap/test_cmd.pcap");
  REQUIRE(datagrams.size() == 10);
  const Command expected[] = {Command::kResetFpga,     Command::kResetRadar,      Command::kStartRecord,
                              Command::kStopRecord,    Command::kConfigPacketData, Command::kConfigFpga,
                              Command::kConfigEeprom,  Command::kSystemAliveness,  Command::kAsyncStatus,
                              Command::kReadFpgaVersion};
  for (std::size_t i = 0; i < datagrams.size(); ++i) {
    const auto& g = datagrams[i];
    CHECK(g.dst_port == kConfigPort);
    CHECK(g.src_ip == 0xC0A821B4u);  // 192.168.33.180, the board
    const auto r = parse_response(g.payload);
    REQUIRE(r);
    CHECK(r->code == expected[i]);
    const auto rebuilt = build_response(r->code, r->status);
    CHECK(std::vector<std::uint8_t>(rebuilt.begin(), rebuilt.end()) == g.payload);
  }
  // Every command succeeded (status 0) but the async status and the version.
  CHECK(parse_response(datagrams[0].payload)->status == 0);
  CHECK(parse_response(datagrams[8].payload)->status == 0);  // async mask 0 on this board
  const auto version = decode_fpga_version(parse_response(datagrams[9].payload)->status);
  CHECK(version.major == 2);  // 0x0402: major bits 0-6 = 2, minor bits 7-13 = 8
  CHECK(version.minor == 8);
  CHECK_FALSE(version.playback);
  CHECK(encode_fpga_version(version) == 0x0402);
  CHECK(describe_async_status(kNoLvdsData | kNoHeader) == "NO_LVDS_DATA|NO_HEADER");
}

TEST_CASE("the real data packets carry consecutive sequence numbers and byte counts", "[dca1000]") {
  const auto datagrams = rsrio::test::read_pcap_udp("../shared/data/dca1000-pcap/test_one_frame.pcap");
  std::uint32_t expected_seq = 1;
  std::uint64_t expected_bytes = 0;
  int data_packets = 0;
  for (const auto& g : datagrams) {
    if (g.dst_port != kDataPort) continue;
    const auto h = parse_data_header(g.payload);
    REQUIRE(h);
    CHECK(h->sequence == expected_seq);
    CHECK(h->byte_count == expected_bytes);
    ++expected_seq;
    expected_bytes += g.payload.size() - kDataHeaderSize;
    ++data_packets;
    std::array<std::uint8_t, kDataHeaderSize> again{};
    write_data_header(*h, again);
    CHECK(std::equal(again.begin(), again.end(), g.payload.begin()));
  }
  CHECK(data_packets == 12);
  CHECK(expected_bytes == 16384);  // 11 x 1456 + 368
  CHECK_FALSE(parse_data_header(std::vector<std::uint8_t>(9, 0)));
}
