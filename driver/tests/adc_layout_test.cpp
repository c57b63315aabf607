// ADC byte layouts: the real DCA1000 capture decodes to its published values; every layout
// round-trips; hand-placed bytes land where TI's documentation says.
#include "rsrio/driver/adc_layout.hpp"

#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "test_pcap.hpp"

namespace {

// Payloads of the DCA1000 data packets (UDP port 4098) of a capture, each stripped of its 10-byte
// DCA1000 header (u32 sequence, 48-bit byte count), concatenated in file order.
std::vector<std::uint8_t> dca1000_payloads(const std::string& path) {
  std::vector<std::uint8_t> out;
  for (const auto& g : rsrio::test::read_pcap_udp(path)) {
    if (g.dst_port != 4098) continue;  // the capture also holds config-port (4096) responses
    REQUIRE(g.payload.size() > 10);
    out.insert(out.end(), g.payload.begin() + 10, g.payload.end());
  }
  return out;
}

rsrio::RadarConfig small_config(const std::string& layout, const std::string& order, bool offset_binary) {
  auto c = rsrio::radar_preset("xwr1843");
  c.loops = 3;
  c.chirp.samples_per_chirp = 8;
  c.capture.sample_layout = layout;
  c.capture.iq_order = order;
  c.capture.offset_binary = offset_binary;
  return c;
}

rsrio::AdcCube random_cube(const rsrio::RadarConfig& c, unsigned seed) {
  auto cube = rsrio::AdcCube::for_config(c);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(-32768, 32767);
  for (auto& v : cube.data) v = {float(d(rng)), float(d(rng))};
  return cube;
}

}  // namespace

TEST_CASE("real DCA1000 capture decodes to its published samples (Q first)", "[adc_layout]") {
  const auto bytes = dca1000_payloads("../shared/data/dca1000-pcap/test_one_frame.pcap");
  REQUIRE(bytes.size() == 16384);
  // The capture's radar: 4 RX, 256 samples (xwr18xx_profile.cfg), SDK demo sample swap -> Q first.
  auto c = rsrio::radar_preset("xwr1843");
  c.chirp.samples_per_chirp = 256;
  c.loops = 2;
  c.tx_order = {0, 2};
  c.capture.iq_order = "q_first";
  REQUIRE(rsrio::dca1000_frame_bytes(c) == bytes.size());
  rsrio::AdcCube cube;
  rsrio::decode_dca1000(c, bytes, cube);
  const std::vector<std::pair<int, std::complex<float>>> expected = {
      {415, {-88, 193}},  {671, {-55, 205}},  {1255, {366, -21}}, {1262, {582, 30}},  {1736, {-127, -238}},
      {2394, {745, -301}}, {3293, {-90, -615}}, {3474, {268, -48}}, {4065, {223, 120}}};
  for (const auto& [i, v] : expected) {
    INFO("sample " << i);
    CHECK(cube.data[i] == v);
  }
  // The same bytes read as I first give j * conj(x): I and Q trade places.
  c.capture.iq_order = "i_first";
  rsrio::AdcCube swapped;
  rsrio::decode_dca1000(c, bytes, swapped);
  CHECK(swapped.data[415] == std::complex<float>(193, -88));
}

TEST_CASE("every DCA1000 layout round-trips bit-exactly", "[adc_layout]") {
  for (const char* layout : {"iiqq", "iq"})
    for (const char* order : {"i_first", "q_first"})
      for (bool ob : {false, true}) {
        INFO(layout << " " << order << " offset_binary=" << ob);
        const auto c = small_config(layout, order, ob);
        const auto cube = random_cube(c, 7);
        std::vector<std::uint8_t> bytes;
        rsrio::encode_dca1000(c, cube, bytes);
        REQUIRE(bytes.size() == rsrio::dca1000_frame_bytes(c));
        rsrio::AdcCube back;
        rsrio::decode_dca1000(c, bytes, back);
        CHECK(back.data == cube.data);
      }
}

TEST_CASE("DCA1000 IIQQ bytes sit where TI's readDCA1000 puts them", "[adc_layout]") {
  auto c = small_config("iiqq", "i_first", false);
  auto cube = rsrio::AdcCube::for_config(c);
  // loop 1, slot 2, rx 3, samples 4 and 5 -> chirp block (1*3 + 2)*4 + 3 = 23, group 2 of 4 int16
  cube.at(1, 2, 3, 4) = {100, -200};
  cube.at(1, 2, 3, 5) = {300, -400};
  std::vector<std::uint8_t> bytes;
  rsrio::encode_dca1000(c, cube, bytes);
  const std::size_t base = (23 * 8 + 4) * 4;  // bytes: block * samples * 4 + sample 4 * 4
  auto at = [&](std::size_t o) { return std::int16_t(bytes[o] | bytes[o + 1] << 8); };
  CHECK(at(base + 0) == 100);   // I(4)
  CHECK(at(base + 2) == 300);   // I(5)
  CHECK(at(base + 4) == -200);  // Q(4)
  CHECK(at(base + 6) == -400);  // Q(5)
  // offset binary flips the top bit
  c.capture.offset_binary = true;
  rsrio::encode_dca1000(c, cube, bytes);
  CHECK(std::uint16_t(bytes[base] | bytes[base + 1] << 8) == (100 ^ 0x8000));
}

TEST_CASE("cascade device frames: [loop][chirp][sample][rx] per device, device d = RX 4d..4d+3", "[adc_layout]") {
  auto c = rsrio::radar_preset("mmwcas");
  c.loops = 2;
  c.chirp.samples_per_chirp = 16;
  const auto cube = random_cube(c, 11);
  std::array<std::vector<std::uint8_t>, rsrio::kCascadeDevices> devs;
  rsrio::encode_cascade(c, cube, devs);
  // slave2 (device 2) carries capture RX 8..11; loop 1, chirp 5, sample 7, its rx 3 (capture RX 11)
  const std::size_t k = ((1 * 12 + 5) * 16 + 7) * 4 + 3;
  auto at = [&](std::size_t o) { return float(std::int16_t(devs[2][o] | devs[2][o + 1] << 8)); };
  CHECK(at(4 * k) == cube.at(1, 5, 11, 7).real());
  CHECK(at(4 * k + 2) == cube.at(1, 5, 11, 7).imag());
  std::vector<std::uint8_t> all;
  rsrio::encode_frame(c, cube, all);
  CHECK(all.size() == rsrio::raw_frame_bytes(c));
  rsrio::AdcCube back;
  rsrio::decode_frame(c, all, back);
  CHECK(back.data == cube.data);
}

TEST_CASE("short buffers are refused, samples saturate to int16", "[adc_layout]") {
  const auto c = small_config("iiqq", "i_first", false);
  std::vector<std::uint8_t> bytes(rsrio::dca1000_frame_bytes(c) - 1);
  rsrio::AdcCube cube;
  CHECK_THROWS_AS(rsrio::decode_dca1000(c, bytes, cube), std::invalid_argument);
  cube = rsrio::AdcCube::for_config(c);
  cube.data[0] = {1e6f, -1e6f};
  rsrio::encode_dca1000(c, cube, bytes);
  rsrio::AdcCube back;
  rsrio::decode_dca1000(c, bytes, back);
  CHECK(back.data[0] == std::complex<float>(32767, -32768));
}
