// RecordingReader: walks the data section record by record, never trusting the summary (which a
// crash never got to write).
//
// Everything read from the file is checked before it is used: a record's length against the bytes
// left in the file (so a corrupt length cannot make us allocate more than the file holds, nor more
// than kMaxRecordBytes), a chunk's records against its CRC before any of its messages is returned,
// each record inside a chunk against the chunk's bounds. The first failed check ends reading with
// a RecordingDamage; next() never throws.
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "crc32.hpp"
#include "mcap_format.hpp"
#include "rsrio/recording/recording.hpp"

namespace rsrio {

namespace recording_detail {

std::string_view opcode_name(std::uint8_t opcode) {
  switch (static_cast<Opcode>(opcode)) {
    case Opcode::kHeader: return "header";
    case Opcode::kFooter: return "footer";
    case Opcode::kSchema: return "schema";
    case Opcode::kChannel: return "channel";
    case Opcode::kMessage: return "message";
    case Opcode::kChunk: return "chunk";
    case Opcode::kMessageIndex: return "message index";
    case Opcode::kChunkIndex: return "chunk index";
    case Opcode::kAttachment: return "attachment";
    case Opcode::kAttachmentIndex: return "attachment index";
    case Opcode::kStatistics: return "statistics";
    case Opcode::kMetadata: return "metadata";
    case Opcode::kMetadataIndex: return "metadata index";
    case Opcode::kSummaryOffset: return "summary offset";
    case Opcode::kDataEnd: return "data end";
  }
  return "unknown";
}

}  // namespace recording_detail

namespace {

using recording_detail::ByteBuffer;
using recording_detail::ByteCursor;
using recording_detail::kMagic;
using recording_detail::kRecordPrefixBytes;
using recording_detail::Opcode;
using recording_detail::crc32_update;

/// No record we would ever write comes near this (a chunk holds chunk_bytes plus one message; a
/// raw cascade frame is tens of MB). A bigger length is treated as damage instead of allocated:
/// even a file that is really this large must not make the reader take gigabytes of memory.
constexpr std::uint64_t kMaxRecordBytes = std::uint64_t{1} << 30;

/// Records we skip (indexes, metadata, attachments) are read into memory only up to this size to
/// take part in the data-section CRC; bigger ones are seeked over and the CRC is not checked.
constexpr std::uint64_t kMaxSkippedRecordBytesForCrc = std::uint64_t{16} << 20;

std::string hex32(std::uint32_t value) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08" PRIx32, value);
  return text;
}

std::string record_label(std::uint8_t opcode) {
  const std::string_view name = recording_detail::opcode_name(opcode);
  if (name != "unknown") return std::string(name) + " record";
  char text[48];
  std::snprintf(text, sizeof text, "record with opcode 0x%02x", opcode);
  return text;
}

struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};

struct ChannelInfo {
  std::string topic;
  std::string schema_name;
};

/// Thrown inside the reader to stop at damage; next() turns it into damage(), never lets it out.
struct DamageFound {
  std::uint64_t offset;
  std::string reason;
};

}  // namespace

std::string RecordingDamage::message() const {
  return "recording damaged at byte " + std::to_string(offset) + ": " + reason + " (" +
         std::to_string(messages_read) + " message" + (messages_read == 1 ? "" : "s") + " read before it)";
}

struct RecordingReader::Impl {
  std::string path;
  std::unique_ptr<std::FILE, FileCloser> file;
  std::uint64_t file_size = 0;
  std::string profile;
  std::optional<RecordingDamage> damage;
  bool finished = false;
  std::uint64_t messages_read = 0;

  std::uint64_t position = 0;       // next top-level record
  std::uint32_t data_section_crc = 0;
  bool data_section_crc_known = true;

  std::unordered_map<std::uint16_t, std::string> schema_names;
  std::unordered_map<std::uint16_t, ChannelInfo> channels;

  // The chunk being returned, already CRC-checked.
  ByteBuffer chunk_records;
  std::uint64_t chunk_records_file_offset = 0;  // where chunk_records[0] is in the file
  std::size_t chunk_position = 0;
  bool in_chunk = false;

  ByteBuffer scratch;  // small records

  [[noreturn]] static void stop(std::uint64_t offset, std::string reason) {
    throw DamageFound{offset, std::move(reason)};
  }

  // Reads exactly `size` bytes at `offset` (the caller has checked they exist).
  void read_at(std::uint64_t offset, std::uint8_t* out, std::size_t size) {
    if (size == 0) return;
    if (fseeko(file.get(), static_cast<off_t>(offset), SEEK_SET) != 0 || std::fread(out, 1, size, file.get()) != size)
      stop(offset, std::string("read error: ") + (std::ferror(file.get()) ? std::strerror(errno) : "file shrank"));
  }

  void open_header() {
    // The magic was checked by the constructor (or the file ends inside it).
    const std::uint64_t header_offset = kMagic.size();
    std::uint8_t prefix[kRecordPrefixBytes];
    if (file_size < header_offset + kRecordPrefixBytes)
      stop(header_offset, "file ends inside the header record (truncated)");
    read_at(header_offset, prefix, sizeof prefix);
    if (prefix[0] != static_cast<std::uint8_t>(Opcode::kHeader))
      stop(header_offset, "the first record is a " + record_label(prefix[0]) + ", not the header");
    const std::uint64_t length = recording_detail::load_le(prefix + 1, 8);
    if (length > file_size - header_offset - kRecordPrefixBytes)
      stop(header_offset, "file ends inside the header record (truncated)");
    if (length > kMaxRecordBytes) stop(header_offset, "header record of " + std::to_string(length) + " bytes");
    scratch.clear();
    read_at(header_offset + kRecordPrefixBytes, scratch.extend(length), length);
    ByteCursor content(scratch.data(), scratch.size());
    std::string_view profile_text;
    if (!content.string(profile_text)) stop(header_offset, "malformed header record (profile)");
    profile = std::string(profile_text);

    data_section_crc = crc32_update(0, kMagic.data(), kMagic.size());
    data_section_crc = crc32_update(data_section_crc, prefix, sizeof prefix);
    data_section_crc = crc32_update(data_section_crc, scratch.data(), scratch.size());
    position = header_offset + kRecordPrefixBytes + length;
  }

  // Schema and Channel records, in a chunk or in the data section. `offset`: the record's place in
  // the file, for damage reports.
  void parse_schema(const std::uint8_t* content, std::size_t size, std::uint64_t offset) {
    ByteCursor cursor(content, size);
    std::uint16_t id = 0;
    std::string_view name;
    if (!cursor.u16(id) || !cursor.string(name)) stop(offset, "malformed schema record");
    schema_names[id] = std::string(name);
  }

  void parse_channel(const std::uint8_t* content, std::size_t size, std::uint64_t offset) {
    ByteCursor cursor(content, size);
    std::uint16_t id = 0;
    std::uint16_t schema_id = 0;
    std::string_view topic;
    if (!cursor.u16(id) || !cursor.u16(schema_id) || !cursor.string(topic)) stop(offset, "malformed channel record");
    ChannelInfo channel;
    channel.topic = std::string(topic);
    if (schema_id != 0) {
      const auto schema = schema_names.find(schema_id);
      if (schema == schema_names.end())
        stop(offset, "channel '" + channel.topic + "' refers to schema " + std::to_string(schema_id) +
                         ", which no earlier schema record defines");
      channel.schema_name = schema->second;
    }
    channels[id] = std::move(channel);
  }

  void parse_message(const std::uint8_t* content, std::size_t size, std::uint64_t offset, RecordedMessage& out) {
    ByteCursor cursor(content, size);
    std::uint16_t channel_id = 0;
    if (!cursor.u16(channel_id) || !cursor.u32(out.sequence) || !cursor.u64(out.log_time_ns) ||
        !cursor.u64(out.publish_time_ns))
      stop(offset, "malformed message record (shorter than its fixed fields)");
    const auto channel = channels.find(channel_id);
    if (channel == channels.end())
      stop(offset, "message on channel " + std::to_string(channel_id) + ", which no earlier channel record defines");
    out.topic = channel->second.topic;
    out.schema_name = channel->second.schema_name;
    out.cdr.assign(cursor.here(), cursor.here() + cursor.remaining());
  }

  // The next record inside the open chunk: true with `out` filled for a message; false at the end
  // of the chunk.
  bool next_in_chunk(RecordedMessage& out) {
    while (chunk_position < chunk_records.size()) {
      const std::uint64_t record_offset = chunk_records_file_offset + chunk_position;
      ByteCursor cursor(chunk_records.data() + chunk_position, chunk_records.size() - chunk_position);
      std::uint8_t opcode = 0;
      std::uint64_t length = 0;
      if (!cursor.u8(opcode) || !cursor.u64(length) || length > cursor.remaining())
        stop(record_offset, "malformed record inside a chunk (its length runs past the chunk)");
      const std::uint8_t* content = cursor.here();
      chunk_position += kRecordPrefixBytes + static_cast<std::size_t>(length);
      switch (static_cast<Opcode>(opcode)) {
        case Opcode::kSchema: parse_schema(content, length, record_offset); break;
        case Opcode::kChannel: parse_channel(content, length, record_offset); break;
        case Opcode::kMessage: parse_message(content, length, record_offset, out); return true;
        default: break;  // other records may appear in later MCAP versions: skip
      }
    }
    in_chunk = false;
    return false;
  }

  // Loads the chunk record at `offset` (prefix already read), checks its CRC and opens it.
  void open_chunk(std::uint64_t offset, const std::uint8_t* prefix, std::uint64_t length) {
    constexpr std::size_t kFixed = recording_detail::kChunkTimesSizeCrcBytes + 4;  // up to the compression text
    if (length < kFixed + 8) stop(offset, "malformed chunk record (" + std::to_string(length) + " bytes)");
    std::uint8_t fixed[kFixed];
    read_at(offset + kRecordPrefixBytes, fixed, kFixed);
    const std::uint64_t uncompressed_size = recording_detail::load_le(fixed + 16, 8);
    const auto stored_crc = static_cast<std::uint32_t>(recording_detail::load_le(fixed + 24, 4));
    const std::uint64_t compression_length = recording_detail::load_le(fixed + 28, 4);
    if (compression_length > length - kFixed - 8)
      stop(offset, "malformed chunk record (compression name runs past the record)");
    std::string compression(static_cast<std::size_t>(compression_length), '\0');
    read_at(offset + kRecordPrefixBytes + kFixed, reinterpret_cast<std::uint8_t*>(compression.data()),
            compression.size());
    std::uint8_t records_length_bytes[8];
    const std::uint64_t records_length_at = offset + kRecordPrefixBytes + kFixed + compression_length;
    read_at(records_length_at, records_length_bytes, 8);
    const std::uint64_t records_length = recording_detail::load_le(records_length_bytes, 8);
    const std::uint64_t records_room = length - kFixed - compression_length - 8;
    if (records_length > records_room) stop(offset, "malformed chunk record (records run past the record)");
    if (!compression.empty())
      stop(offset, "chunk compressed with '" + compression + "', which this reader does not decompress");
    if (uncompressed_size != records_length)
      stop(offset, "malformed chunk record (uncompressed size " + std::to_string(uncompressed_size) +
                       " differs from its " + std::to_string(records_length) + " bytes of records)");

    chunk_records.clear();
    chunk_records_file_offset = records_length_at + 8;
    read_at(chunk_records_file_offset, chunk_records.extend(static_cast<std::size_t>(records_length)),
            static_cast<std::size_t>(records_length));
    const std::uint32_t records_crc = crc32_update(0, chunk_records.data(), chunk_records.size());
    if (stored_crc != 0 && stored_crc != records_crc)
      stop(offset, "chunk CRC mismatch (stored " + hex32(stored_crc) + ", computed " + hex32(records_crc) + ")");

    // The data-section CRC over this record, reusing the records' CRC.
    data_section_crc = crc32_update(data_section_crc, prefix, kRecordPrefixBytes);
    data_section_crc = crc32_update(data_section_crc, fixed, kFixed);
    data_section_crc = crc32_update(data_section_crc, compression.data(), compression.size());
    data_section_crc = crc32_update(data_section_crc, records_length_bytes, 8);
    data_section_crc = recording_detail::crc32_combine(data_section_crc, records_crc, records_length);
    const std::uint64_t trailing = records_room - records_length;  // fields added by later versions
    if (trailing != 0) skip_for_crc(records_length_at + 8 + records_length, trailing);

    chunk_position = 0;
    in_chunk = true;
  }

  // Bytes we do not interpret but that belong to the data-section CRC.
  void skip_for_crc(std::uint64_t offset, std::uint64_t size) {
    if (!data_section_crc_known) return;
    if (size > kMaxSkippedRecordBytesForCrc) {
      data_section_crc_known = false;
      return;
    }
    scratch.clear();
    read_at(offset, scratch.extend(static_cast<std::size_t>(size)), static_cast<std::size_t>(size));
    data_section_crc = crc32_update(data_section_crc, scratch.data(), scratch.size());
  }

  // After DataEnd: the data is complete. Check the data CRC and that a summary and footer follow,
  // since index-based readers (rosbags, ros2 bag) cannot open the file without them.
  void check_end(std::uint64_t data_end_offset, std::uint32_t stored_crc) {
    if (stored_crc != 0 && data_section_crc_known && stored_crc != data_section_crc)
      stop(data_end_offset, "data section CRC mismatch (stored " + hex32(stored_crc) + ", computed " +
                                hex32(data_section_crc) + "): a record outside the chunks is corrupt");
    const std::uint64_t summary_start = position;
    const std::uint64_t tail = kMagic.size() + recording_detail::kFooterRecordBytes;
    if (file_size < summary_start + tail)
      stop(summary_start, "summary or footer missing after the data end record (truncated; all messages were read)");
    std::uint8_t footer[recording_detail::kFooterRecordBytes + kMagic.size()];
    read_at(file_size - tail, footer, sizeof footer);
    const bool footer_ok = footer[0] == static_cast<std::uint8_t>(Opcode::kFooter) &&
                           recording_detail::load_le(footer + 1, 8) == recording_detail::kFooterContentBytes &&
                           std::memcmp(footer + recording_detail::kFooterRecordBytes, kMagic.data(), kMagic.size()) == 0;
    if (!footer_ok)
      stop(summary_start, "no footer and closing magic at the end of the file (truncated or corrupt; all messages "
                          "were read)");
  }

  bool next_top_level(RecordedMessage& out) {
    for (;;) {
      if (in_chunk && next_in_chunk(out)) return true;
      const std::uint64_t offset = position;
      if (offset == file_size)
        stop(offset, "file ends without a data end record (truncated after " + std::to_string(offset) + " bytes)");
      if (file_size - offset < kRecordPrefixBytes) stop(offset, "file ends inside a record header (truncated)");
      std::uint8_t prefix[kRecordPrefixBytes];
      read_at(offset, prefix, sizeof prefix);
      const std::uint8_t opcode = prefix[0];
      const std::uint64_t length = recording_detail::load_le(prefix + 1, 8);
      if (opcode == 0)
        stop(offset, "invalid record opcode 0x00 (zero-filled or corrupt data)");
      if (length > file_size - offset - kRecordPrefixBytes)
        stop(offset, "file ends inside a " + record_label(opcode) + " (truncated)");
      if (length > kMaxRecordBytes)
        stop(offset, record_label(opcode) + " of " + std::to_string(length) + " bytes exceeds the reader's limit of " +
                         std::to_string(kMaxRecordBytes) + " bytes (corrupt length?)");
      position = offset + kRecordPrefixBytes + length;

      switch (static_cast<Opcode>(opcode)) {
        case Opcode::kChunk: open_chunk(offset, prefix, length); break;
        case Opcode::kSchema:
        case Opcode::kChannel:
        case Opcode::kMessage: {
          scratch.clear();
          read_at(offset + kRecordPrefixBytes, scratch.extend(static_cast<std::size_t>(length)),
                  static_cast<std::size_t>(length));
          data_section_crc = crc32_update(data_section_crc, prefix, sizeof prefix);
          data_section_crc = crc32_update(data_section_crc, scratch.data(), scratch.size());
          if (opcode == static_cast<std::uint8_t>(Opcode::kSchema)) {
            parse_schema(scratch.data(), scratch.size(), offset);
          } else if (opcode == static_cast<std::uint8_t>(Opcode::kChannel)) {
            parse_channel(scratch.data(), scratch.size(), offset);
          } else {
            parse_message(scratch.data(), scratch.size(), offset, out);
            return true;
          }
          break;
        }
        case Opcode::kDataEnd: {
          if (length < recording_detail::kDataEndContentBytes) stop(offset, "malformed data end record");
          std::uint8_t crc_bytes[4];
          read_at(offset + kRecordPrefixBytes, crc_bytes, 4);
          check_end(offset, static_cast<std::uint32_t>(recording_detail::load_le(crc_bytes, 4)));
          return false;
        }
        case Opcode::kFooter:
          // A file without a data end record (allowed by older writers): the data ends here.
          return false;
        case Opcode::kHeader: stop(offset, "a second header record");
        default:
          // Message indexes, metadata, attachments, summary records, extensions: not needed to
          // return the messages.
          if (data_section_crc_known) data_section_crc = crc32_update(data_section_crc, prefix, sizeof prefix);
          skip_for_crc(offset + kRecordPrefixBytes, length);
          break;
      }
    }
  }
};

RecordingReader::RecordingReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  Impl& r = *impl_;
  r.path = path;
  r.file.reset(std::fopen(path.c_str(), "rb"));
  if (!r.file) throw std::runtime_error("recording " + path + ": cannot open: " + std::strerror(errno));
  struct stat info {};
  if (fstat(fileno(r.file.get()), &info) != 0)
    throw std::runtime_error("recording " + path + ": cannot stat: " + std::strerror(errno));
  if (!S_ISREG(info.st_mode)) throw std::runtime_error("recording " + path + ": not a regular file");
  r.file_size = static_cast<std::uint64_t>(info.st_size);

  std::uint8_t magic[kMagic.size()] = {};
  const std::size_t present = static_cast<std::size_t>(std::min<std::uint64_t>(r.file_size, kMagic.size()));
  if (std::fread(magic, 1, present, r.file.get()) != present)
    throw std::runtime_error("recording " + path + ": cannot read: " + std::strerror(errno));
  if (std::memcmp(magic, kMagic.data(), present) != 0)
    throw std::runtime_error("recording " + path + ": not an MCAP file (it does not start with the MCAP magic)");

  try {
    if (present < kMagic.size()) Impl::stop(0, "file ends inside the MCAP magic (truncated)");
    r.open_header();
  } catch (const DamageFound& found) {
    r.damage = RecordingDamage{found.offset, found.reason, 0};
    r.finished = true;
  }
}

RecordingReader::~RecordingReader() = default;

bool RecordingReader::next(RecordedMessage& out) {
  Impl& r = *impl_;
  if (r.finished) return false;
  try {
    if (r.next_top_level(out)) {
      ++r.messages_read;
      return true;
    }
  } catch (const DamageFound& found) {
    r.damage = RecordingDamage{found.offset, found.reason, r.messages_read};
  } catch (const std::exception& e) {  // e.g. std::bad_alloc: still a clean stop
    r.damage = RecordingDamage{r.position, std::string("cannot read on: ") + e.what(), r.messages_read};
  }
  r.finished = true;
  return false;
}

const std::optional<RecordingDamage>& RecordingReader::damage() const { return impl_->damage; }

const std::string& RecordingReader::profile() const { return impl_->profile; }

}  // namespace rsrio
