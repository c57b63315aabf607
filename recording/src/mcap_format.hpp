// The MCAP container format (foxglove/mcap docs/specification/README.md), the parts rsrio writes
// and reads: magic, opcodes, the fixed-size parts of records, little-endian encoding, and a byte
// buffer that grows without zero-filling (a raw frame is serialised straight into it).
//
// Every record is <opcode u8><content length u64><content>; integers are little-endian; a String
// is <u32 byte length><UTF-8 bytes>; a Map or Array is <u32 byte length><entries>.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string_view>

namespace rsrio::recording_detail {

inline constexpr std::array<std::uint8_t, 8> kMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum class Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

/// For error messages: "chunk", "message index", ...
std::string_view opcode_name(std::uint8_t opcode);

// ---- record layouts (sizes of the fixed parts, in bytes) ---------------------------------------
inline constexpr std::size_t kRecordPrefixBytes = 1 + 8;  // opcode + content length

// Message: channel_id u16, sequence u32, log_time u64, publish_time u64, then the data.
inline constexpr std::size_t kMessageFixedBytes = 2 + 4 + 8 + 8;
static_assert(kMessageFixedBytes == 22);

// Chunk: message_start_time u64, message_end_time u64, uncompressed_size u64, uncompressed_crc u32,
// compression String, records (u64 length + bytes).
inline constexpr std::size_t kChunkTimesSizeCrcBytes = 8 + 8 + 8 + 4;
/// Prefix and fields of an uncompressed chunk up to its first record: rosbags seeks exactly this
/// far past the chunk start (storage_mcap.py: chunk_start_offset + 9 + 40 + len(compression)).
inline constexpr std::size_t kUncompressedChunkHeaderBytes = kRecordPrefixBytes + kChunkTimesSizeCrcBytes + 4 + 8;
static_assert(kUncompressedChunkHeaderBytes == 9 + 40);

// Message index: channel_id u16, Array<(log_time u64, offset u64)>.
inline constexpr std::size_t kMessageIndexEntryBytes = 8 + 8;
/// rosbags derives per-channel message counts from the distance between message index records:
/// count = (length - 15) / 16, which holds only for exactly this layout.
inline constexpr std::size_t kMessageIndexRecordFixedBytes = kRecordPrefixBytes + 2 + 4;
static_assert(kMessageIndexRecordFixedBytes == 15);

// Statistics: message_count u64, schema_count u16, channel_count u32, attachment_count u32,
// metadata_count u32, chunk_count u32, message_start_time u64, message_end_time u64, then the
// channel_message_counts Map<u16, u64>.
inline constexpr std::size_t kStatisticsFixedBytes = 8 + 2 + 4 + 4 + 4 + 4 + 8 + 8;
static_assert(kStatisticsFixedBytes == 42);  // rosbags reads exactly 42 bytes ('<QHIIIIQQ')

// Summary offset: group_opcode u8, group_start u64, group_length u64.
inline constexpr std::size_t kSummaryOffsetContentBytes = 1 + 8 + 8;

// Data end: data_section_crc u32.
inline constexpr std::size_t kDataEndContentBytes = 4;

// Footer: summary_start u64, summary_offset_start u64, summary_crc u32. Readers find it at a fixed
// distance from the end of the file.
inline constexpr std::size_t kFooterContentBytes = 8 + 8 + 4;
inline constexpr std::size_t kFooterRecordBytes = kRecordPrefixBytes + kFooterContentBytes;
static_assert(kFooterRecordBytes + kMagic.size() == 37);  // rosbags: seek(-37, SEEK_END)

// ---- little-endian encoding ---------------------------------------------------------------------
inline void store_le(std::uint8_t* out, std::uint64_t value, std::size_t bytes) {
  for (std::size_t i = 0; i < bytes; ++i) out[i] = static_cast<std::uint8_t>(value >> (8 * i));
}

inline std::uint64_t load_le(const std::uint8_t* in, std::size_t bytes) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < bytes; ++i) value |= static_cast<std::uint64_t>(in[i]) << (8 * i);
  return value;
}

/// A growable byte buffer. Unlike std::vector, growing does not zero the new bytes (the caller is
/// about to overwrite them), and large buffers grow with realloc, which moves pages instead of
/// copying them.
class ByteBuffer {
 public:
  ByteBuffer() = default;
  ByteBuffer(const ByteBuffer&) = delete;
  ByteBuffer& operator=(const ByteBuffer&) = delete;

  std::uint8_t* data() { return data_.get(); }
  const std::uint8_t* data() const { return data_.get(); }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  void clear() { size_ = 0; }

  void reserve(std::size_t capacity) {
    if (capacity <= capacity_) return;
    void* grown = std::realloc(data_.get(), capacity);
    if (grown == nullptr) throw std::bad_alloc();
    static_cast<void>(data_.release());
    data_.reset(static_cast<std::uint8_t*>(grown));
    capacity_ = capacity;
  }

  /// Makes room for `count` more bytes and returns where they start; size() grows by `count`.
  std::uint8_t* extend(std::size_t count) {
    if (count > capacity_ - size_) reserve(std::max(size_ + count, capacity_ + capacity_ / 2));
    std::uint8_t* start = data_.get() + size_;
    size_ += count;
    return start;
  }
  /// Gives back the last `count` bytes (after a serialiser used less than it was offered).
  void shrink_by(std::size_t count) { size_ -= count; }

  void append(const void* bytes, std::size_t count) {
    if (count != 0) std::memcpy(extend(count), bytes, count);
  }
  void u8(std::uint8_t value) { *extend(1) = value; }
  void u16(std::uint16_t value) { store_le(extend(2), value, 2); }
  void u32(std::uint32_t value) { store_le(extend(4), value, 4); }
  void u64(std::uint64_t value) { store_le(extend(8), value, 8); }
  void string(std::string_view text) {
    u32(static_cast<std::uint32_t>(text.size()));
    append(text.data(), text.size());
  }
  void record_prefix(Opcode opcode, std::uint64_t content_bytes) {
    u8(static_cast<std::uint8_t>(opcode));
    u64(content_bytes);
  }
  /// Patches a little-endian u32/u64 written earlier (lengths known only afterwards).
  void patch_u32(std::size_t offset, std::uint32_t value) { store_le(data_.get() + offset, value, 4); }
  void patch_u64(std::size_t offset, std::uint64_t value) { store_le(data_.get() + offset, value, 8); }

 private:
  struct FreeDeleter {
    void operator()(std::uint8_t* p) const { std::free(p); }
  };
  std::unique_ptr<std::uint8_t, FreeDeleter> data_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

/// Bounds-checked little-endian reads from a byte range; every read reports failure instead of
/// running past the end, so a corrupt length can never make the reader leave its buffer.
class ByteCursor {
 public:
  ByteCursor(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t position() const { return position_; }
  std::size_t remaining() const { return size_ - position_; }
  const std::uint8_t* here() const { return data_ + position_; }

  bool skip(std::uint64_t count) {
    if (count > remaining()) return false;
    position_ += static_cast<std::size_t>(count);
    return true;
  }
  bool u16(std::uint16_t& value) { return fixed(value, 2); }
  bool u32(std::uint32_t& value) { return fixed(value, 4); }
  bool u64(std::uint64_t& value) { return fixed(value, 8); }
  bool u8(std::uint8_t& value) { return fixed(value, 1); }
  /// A String (u32 length + bytes), viewed in place.
  bool string(std::string_view& text) {
    std::uint32_t length = 0;
    if (!u32(length) || length > remaining()) return false;
    text = std::string_view(reinterpret_cast<const char*>(here()), length);
    position_ += length;
    return true;
  }

 private:
  template <typename T>
  bool fixed(T& value, std::size_t bytes) {
    if (bytes > remaining()) return false;
    value = static_cast<T>(load_le(here(), bytes));
    position_ += bytes;
    return true;
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

}  // namespace rsrio::recording_detail
