#include "crc32.hpp"

#include <array>

namespace rsrio::recording_detail {

namespace {

constexpr std::uint32_t kPolynomialReflected = 0xEDB88320u;

// kTables[0] is the classic byte table; kTables[k][b] is the CRC contribution of byte b followed
// by k zero bytes, so eight bytes can be folded in with eight independent lookups.
using SliceTables = std::array<std::array<std::uint32_t, 256>, 8>;

constexpr SliceTables make_tables() {
  SliceTables tables{};
  for (std::uint32_t byte = 0; byte < 256; ++byte) {
    std::uint32_t crc = byte;
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1u) ? (crc >> 1) ^ kPolynomialReflected : crc >> 1;
    tables[0][byte] = crc;
  }
  for (std::size_t slice = 1; slice < tables.size(); ++slice)
    for (std::size_t byte = 0; byte < 256; ++byte) {
      const std::uint32_t previous = tables[slice - 1][byte];
      tables[slice][byte] = (previous >> 8) ^ tables[0][previous & 0xFFu];
    }
  return tables;
}

constexpr SliceTables kTables = make_tables();
static_assert(kTables[0][1] == 0x77073096u, "CRC-32 table does not match the IEEE polynomial");

// Little-endian load from bytes: the slicing order is defined on the byte stream, so this is
// correct on any host (compilers turn it into one load on little-endian machines).
inline std::uint32_t load_le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

// Polynomials over GF(2) modulo the CRC polynomial, in the reflected bit order the CRC uses:
// bit 31 holds the coefficient of x^0, bit 0 that of x^31.
std::uint32_t multiply_mod_p(std::uint32_t a, std::uint32_t b) {
  std::uint32_t product = 0;
  for (int power = 0; power < 32; ++power) {  // b holds (original b) * x^power
    if (a & (0x80000000u >> power)) product ^= b;
    b = (b & 1u) ? (b >> 1) ^ kPolynomialReflected : b >> 1;
  }
  return product;
}

// x^(8 n) mod p: appending n zero bytes to a message multiplies its CRC register by this.
std::uint32_t x_pow_8n_mod_p(std::uint64_t n) {
  std::uint32_t result = 0x80000000u;          // x^0
  std::uint32_t square = 0x80000000u >> 8;     // x^8, then x^16, x^32, ...
  while (n != 0) {
    if (n & 1u) result = multiply_mod_p(result, square);
    square = multiply_mod_p(square, square);
    n >>= 1;
  }
  return result;
}

}  // namespace

std::uint32_t crc32_update(std::uint32_t crc, const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::uint32_t state = ~crc;
  while (size >= 8) {
    const std::uint32_t low = load_le32(p) ^ state;
    const std::uint32_t high = load_le32(p + 4);
    state = kTables[7][low & 0xFFu] ^ kTables[6][(low >> 8) & 0xFFu] ^ kTables[5][(low >> 16) & 0xFFu] ^
            kTables[4][low >> 24] ^ kTables[3][high & 0xFFu] ^ kTables[2][(high >> 8) & 0xFFu] ^
            kTables[1][(high >> 16) & 0xFFu] ^ kTables[0][high >> 24];
    p += 8;
    size -= 8;
  }
  while (size-- != 0) state = (state >> 8) ^ kTables[0][(state ^ *p++) & 0xFFu];
  return ~state;
}

std::uint32_t crc32_combine(std::uint32_t crc_a, std::uint32_t crc_b, std::uint64_t size_b) {
  // The pre- and post-conditioning XORs cancel out, so for the standard CRC-32:
  // crc(A B) = crc(A) * x^(8 |B|) mod p  XOR  crc(B).
  return multiply_mod_p(x_pow_8n_mod_p(size_b), crc_a) ^ crc_b;
}

}  // namespace rsrio::recording_detail
