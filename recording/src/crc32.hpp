// CRC-32 (IEEE 802.3: reflected polynomial 0xEDB88320, initial and final XOR 0xFFFFFFFF), the
// checksum MCAP uses for chunks, the data section and the summary. zlib's crc32() computes the
// same function, so independent tools can check our files.
//
// Slicing-by-8 tables: a raw radar frame of a few megabytes is checksummed once per write, so the
// byte-at-a-time loop (8x slower) would dominate the cost of recording it.
#pragma once

#include <cstddef>
#include <cstdint>

namespace rsrio::recording_detail {

/// Continues a CRC: `crc` is the CRC of the bytes before `data` (0 for none), the result is the
/// CRC of all of them. Same convention as zlib's crc32(crc, buf, len).
std::uint32_t crc32_update(std::uint32_t crc, const void* data, std::size_t size);

inline std::uint32_t crc32(const void* data, std::size_t size) { return crc32_update(0, data, size); }

/// The CRC of A followed by B, from crc(A), crc(B) and the length of B, without touching the bytes
/// again (O(log length)). Lets the data-section CRC reuse each chunk's CRC.
std::uint32_t crc32_combine(std::uint32_t crc_a, std::uint32_t crc_b, std::uint64_t size_b);

}  // namespace rsrio::recording_detail
