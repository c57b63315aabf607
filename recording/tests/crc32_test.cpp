// CRC-32 against its published check value and a bitwise reference; crc32_combine against
// checksumming the concatenation.
#include <cstdint>
#include <random>
#include <string_view>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "crc32.hpp"

using rsrio::recording_detail::crc32;
using rsrio::recording_detail::crc32_combine;
using rsrio::recording_detail::crc32_update;

namespace {

// The textbook bit-at-a-time CRC-32, independent of the table construction.
std::uint32_t reference_crc32(const std::uint8_t* data, std::size_t size) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

std::vector<std::uint8_t> random_bytes(std::size_t size, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::vector<std::uint8_t> bytes(size);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(random());
  return bytes;
}

}  // namespace

TEST_CASE("recording: CRC-32 matches the standard check value and a bitwise reference", "[recording][crc32]") {
  constexpr std::string_view kCheck = "123456789";
  REQUIRE(crc32(kCheck.data(), kCheck.size()) == 0xCBF43926u);  // the CRC-32/ISO-HDLC check value
  REQUIRE(crc32(nullptr, 0) == 0u);

  // Every length up to a few slices, at every misalignment.
  const std::vector<std::uint8_t> bytes = random_bytes(300, 1);
  for (std::size_t start = 0; start < 9; ++start)
    for (std::size_t size = 0; size + start <= 80; ++size)
      REQUIRE(crc32(bytes.data() + start, size) == reference_crc32(bytes.data() + start, size));
  REQUIRE(crc32(bytes.data(), bytes.size()) == reference_crc32(bytes.data(), bytes.size()));
}

TEST_CASE("recording: CRC-32 can be continued and combined", "[recording][crc32]") {
  const std::vector<std::uint8_t> bytes = random_bytes(100'003, 2);
  const std::uint32_t whole = crc32(bytes.data(), bytes.size());
  for (std::size_t split : {std::size_t{0}, std::size_t{1}, std::size_t{7}, std::size_t{4096}, std::size_t{99'999},
                            bytes.size()}) {
    const std::uint32_t a = crc32(bytes.data(), split);
    const std::uint32_t b = crc32(bytes.data() + split, bytes.size() - split);
    REQUIRE(crc32_update(a, bytes.data() + split, bytes.size() - split) == whole);
    REQUIRE(crc32_combine(a, b, bytes.size() - split) == whole);
  }
  // Lengths far beyond what we could checksum here: combine must still be consistent.
  const std::uint32_t a = crc32(bytes.data(), 10);
  const std::uint32_t b = crc32(bytes.data() + 10, 20);
  const std::uint32_t c = crc32(bytes.data() + 30, 30);
  REQUIRE(crc32_combine(crc32_combine(a, b, 20), c, 30) == crc32(bytes.data(), 60));
}
