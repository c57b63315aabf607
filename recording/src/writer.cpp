// RecordingWriter: MCAP with the ROS 2 profile, written append-only so that a crash loses at most
// the open chunk.
//
// Messages are serialised by the fastddsgen PubSubTypes straight into the open chunk (no
// intermediate copy) and checksummed right after, while the bytes are still in cache; when the
// chunk is written, its CRC is folded into the data-section CRC with crc32_combine instead of a
// second pass. A 3 MB raw frame therefore costs one copy of its ADC bytes, one CRC pass and the
// write() itself.
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include <spdlog/spdlog.h>

#include "crc32.hpp"
#include "mcap_format.hpp"
#include "message_types.hpp"
#include "ros2_msg_definitions.hpp"
#include "rsrio/common/version.hpp"
#include "rsrio/recording/recording.hpp"

namespace rsrio {

namespace {

using recording_detail::BorrowedPayload;
using recording_detail::ByteBuffer;
using recording_detail::kCdrRepresentation;
using recording_detail::kMessageFixedBytes;
using recording_detail::kRecordPrefixBytes;
using recording_detail::MessageType;
using recording_detail::Opcode;
using recording_detail::crc32;
using recording_detail::crc32_combine;
using recording_detail::crc32_update;

constexpr std::string_view kProfile = "ros2";
constexpr std::string_view kSchemaEncoding = "ros2msg";
constexpr std::string_view kMessageEncoding = "cdr";
constexpr std::string_view kCompression = "";  // uncompressed: no lz4/zstd dependency
constexpr int kRosbag2MetadataVersion = 9;      // rosbag2 since Jazzy; rosbags 0.10.9 reads <= 9

// ---- rosbag2 metadata (YAML) --------------------------------------------------------------------

std::string yaml_quoted(std::string_view text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

/// The QoS rsrio's topics are offered with, as rosbag2 (format version 9) serialises a list of
/// QoS profiles: policies by name, durations as {sec, nsec}, infinite = RMW_DURATION_INFINITE.
/// Each line is prefixed with `indent` spaces. rosbag2 requires this in every channel's metadata
/// (key "offered_qos_profiles") and uses it to create the publishers when playing back.
std::string offered_qos_profiles_yaml(std::size_t indent) {
  const std::string pad(indent, ' ');
  const std::string infinite = "sec: 9223372036\n" + pad + "    nsec: 854775807";
  return pad + "- history: keep_last\n" +                           //
         pad + "  depth: 10\n" +                                    //
         pad + "  reliability: reliable\n" +                        //
         pad + "  durability: volatile\n" +                         //
         pad + "  deadline:\n" + pad + "    " + infinite + "\n" +   //
         pad + "  lifespan:\n" + pad + "    " + infinite + "\n" +   //
         pad + "  liveliness: automatic\n" +                        //
         pad + "  liveliness_lease_duration:\n" + pad + "    " + infinite + "\n" +
         pad + "  avoid_ros_namespace_conventions: false";
}

struct SchemaState {
  std::uint16_t id = 0;
  std::string name;
  std::string data;
};

struct ChannelState {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string schema_name;
  std::uint64_t message_count = 0;
  /// (log time, offset of the message record in the open chunk's records), for its MessageIndex.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> open_chunk_index;
};

struct ChunkIndexState {
  std::uint64_t message_start_time = 0;
  std::uint64_t message_end_time = 0;
  std::uint64_t chunk_start_offset = 0;
  std::uint64_t chunk_length = 0;
  std::vector<std::pair<std::uint16_t, std::uint64_t>> message_index_offsets;
  std::uint64_t message_index_length = 0;
  std::uint64_t records_size = 0;
};

// Records whose length is known only once their content is written: prefix with a placeholder
// length, patched by end_record.
std::size_t begin_record(ByteBuffer& out, Opcode opcode) {
  const std::size_t start = out.size();
  out.record_prefix(opcode, 0);
  return start;
}
void end_record(ByteBuffer& out, std::size_t start) {
  out.patch_u64(start + 1, out.size() - start - kRecordPrefixBytes);
}

void append_schema_record(ByteBuffer& out, const SchemaState& schema) {
  const std::size_t start = begin_record(out, Opcode::kSchema);
  out.u16(schema.id);
  out.string(schema.name);
  out.string(kSchemaEncoding);
  out.string(schema.data);  // uint32 length-prefixed bytes: same encoding as a String
  end_record(out, start);
}

void append_channel_record(ByteBuffer& out, const ChannelState& channel) {
  static const std::string qos = offered_qos_profiles_yaml(0);
  const std::size_t start = begin_record(out, Opcode::kChannel);
  out.u16(channel.id);
  out.u16(channel.schema_id);
  out.string(channel.topic);
  out.string(kMessageEncoding);
  const std::size_t metadata_length_at = out.size();
  out.u32(0);
  out.string("offered_qos_profiles");
  out.string(qos);
  out.patch_u32(metadata_length_at, static_cast<std::uint32_t>(out.size() - metadata_length_at - 4));
  end_record(out, start);
}

struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};

}  // namespace

struct RecordingWriter::Impl {
  std::string path;
  RecordingWriterOptions options;
  std::unique_ptr<std::FILE, FileCloser> file;
  bool closed = false;
  bool failed = false;

  std::uint64_t file_offset = 0;
  std::uint32_t data_section_crc = 0;  // of every byte written so far before DataEnd

  std::vector<SchemaState> schemas;    // id = index + 1 (0 means "no schema")
  std::vector<ChannelState> channels;  // id = index + 1 (rosbags drops channel id 0: it is falsy)
  std::unordered_map<std::string, std::size_t> channel_index_by_topic;

  ByteBuffer chunk;  // the open chunk's records
  std::uint32_t chunk_crc = 0;
  std::uint64_t chunk_start_time = 0;
  std::uint64_t chunk_end_time = 0;
  std::uint64_t chunk_messages = 0;
  std::vector<ChunkIndexState> chunk_indexes;

  std::uint64_t message_count = 0;
  std::uint64_t first_log_time = 0;
  std::uint64_t last_log_time = 0;

  std::tuple<rsrio_msgs::msg::RadarFramePubSubType, sensor_msgs::msg::ImuPubSubType,
             nav_msgs::msg::OdometryPubSubType, sensor_msgs::msg::PointCloud2PubSubType,
             geometry_msgs::msg::PoseStampedPubSubType>
      types;

  [[noreturn]] void fail_io(const std::string& what) {
    failed = true;
    throw std::runtime_error("recording " + path + ": " + what + ": " + std::strerror(errno));
  }

  // Writes bytes at the end of the file; `in_data_section` bytes also go into the data CRC.
  void emit(const std::uint8_t* bytes, std::size_t size, bool in_data_section) {
    if (size != 0 && std::fwrite(bytes, 1, size, file.get()) != size) fail_io("cannot write");
    file_offset += size;
    if (in_data_section) data_section_crc = crc32_update(data_section_crc, bytes, size);
  }
  void emit(const ByteBuffer& bytes, bool in_data_section) { emit(bytes.data(), bytes.size(), in_data_section); }

  void flush() {
    if (std::fflush(file.get()) != 0) fail_io("cannot flush");
  }

  void check_writable() const {
    if (closed) throw std::logic_error("recording " + path + ": write after close()");
    if (failed) throw std::runtime_error("recording " + path + ": an earlier write failed");
  }

  // Appends a record built by `build` to the open chunk and adds it to the chunk CRC.
  template <typename Build>
  void append_to_chunk(Build&& build) {
    const std::size_t start = chunk.size();
    build(chunk);
    chunk_crc = crc32_update(chunk_crc, chunk.data() + start, chunk.size() - start);
  }

  std::uint16_t schema_id_for(std::string_view schema_name) {
    for (const SchemaState& schema : schemas)
      if (schema.name == schema_name) return schema.id;
    SchemaState schema;
    schema.id = static_cast<std::uint16_t>(schemas.size() + 1);
    schema.name = std::string(schema_name);
    schema.data = recording_detail::ros2msg_schema(schema_name);
    append_to_chunk([&](ByteBuffer& out) { append_schema_record(out, schema); });
    schemas.push_back(std::move(schema));
    return schemas.back().id;
  }

  ChannelState& channel_for(const std::string& topic, std::string_view schema_name) {
    if (const auto found = channel_index_by_topic.find(topic); found != channel_index_by_topic.end()) {
      ChannelState& channel = channels[found->second];
      if (channel.schema_name != schema_name)
        throw std::invalid_argument("recording " + path + ": topic '" + topic + "' already carries " +
                                    channel.schema_name + ", cannot write a " + std::string(schema_name) +
                                    " to it");
      return channel;
    }
    if (topic.empty()) throw std::invalid_argument("recording " + path + ": empty topic name");
    if (channels.size() >= std::numeric_limits<std::uint16_t>::max())
      throw std::invalid_argument("recording " + path + ": more than 65535 topics");
    ChannelState channel;
    channel.id = static_cast<std::uint16_t>(channels.size() + 1);
    channel.schema_id = schema_id_for(schema_name);
    channel.topic = topic;
    channel.schema_name = std::string(schema_name);
    append_to_chunk([&](ByteBuffer& out) { append_channel_record(out, channel); });
    channel_index_by_topic.emplace(topic, channels.size());
    channels.push_back(std::move(channel));
    return channels.back();
  }

  template <typename Message>
  void write_message(const std::string& topic, const Message& message, std::uint64_t log_time_ns) {
    check_writable();
    using Type = MessageType<Message>;
    ChannelState& channel = channel_for(topic, Type::kSchemaName);
    auto& pubsub = std::get<typename Type::PubSubType>(types);

    // The exact XCDR1 size including the 4-byte encapsulation header (the generated size
    // calculator is O(1) for sequences of primitives, so a raw frame costs nothing here).
    const std::uint32_t cdr_capacity = pubsub.calculate_serialized_size(&message, kCdrRepresentation);
    if (cdr_capacity == 0)
      throw std::runtime_error("recording " + path + ": cannot size a " + std::string(Type::kSchemaName) +
                               " for CDR");

    const std::size_t record_offset = chunk.size();
    std::uint8_t* record = chunk.extend(kRecordPrefixBytes + kMessageFixedBytes + cdr_capacity);
    std::uint8_t* cdr = record + kRecordPrefixBytes + kMessageFixedBytes;
    std::uint32_t cdr_size = 0;
    {
      BorrowedPayload payload(cdr, cdr_capacity);
      if (!pubsub.serialize(&message, payload.get(), kCdrRepresentation)) {
        chunk.shrink_by(chunk.size() - record_offset);
        throw std::runtime_error("recording " + path + ": a " + std::string(Type::kSchemaName) +
                                 " does not serialise to CDR (topic " + topic + ")");
      }
      cdr_size = payload.get().length;
    }
    chunk.shrink_by(cdr_capacity - cdr_size);

    const auto& stamp = message.header().stamp();
    const std::int64_t stamp_ns = static_cast<std::int64_t>(stamp.sec()) * 1'000'000'000 + stamp.nanosec();
    const std::uint64_t publish_time_ns = stamp_ns > 0 ? static_cast<std::uint64_t>(stamp_ns) : log_time_ns;

    recording_detail::store_le(record, static_cast<std::uint8_t>(Opcode::kMessage), 1);
    recording_detail::store_le(record + 1, kMessageFixedBytes + cdr_size, 8);
    recording_detail::store_le(record + 9, channel.id, 2);
    recording_detail::store_le(record + 11, static_cast<std::uint32_t>(channel.message_count), 4);
    recording_detail::store_le(record + 15, log_time_ns, 8);
    recording_detail::store_le(record + 23, publish_time_ns, 8);
    chunk_crc = crc32_update(chunk_crc, record, kRecordPrefixBytes + kMessageFixedBytes + cdr_size);

    channel.open_chunk_index.emplace_back(log_time_ns, record_offset);
    ++channel.message_count;
    chunk_start_time = chunk_messages == 0 ? log_time_ns : std::min(chunk_start_time, log_time_ns);
    chunk_end_time = chunk_messages == 0 ? log_time_ns : std::max(chunk_end_time, log_time_ns);
    ++chunk_messages;
    first_log_time = message_count == 0 ? log_time_ns : std::min(first_log_time, log_time_ns);
    last_log_time = message_count == 0 ? log_time_ns : std::max(last_log_time, log_time_ns);
    ++message_count;

    if (chunk.size() >= options.chunk_bytes) close_chunk();
  }

  // Writes the open chunk and its message indexes, then flushes: everything up to here survives a
  // crash of the process.
  void close_chunk() {
    if (chunk.empty()) return;
    ChunkIndexState index;
    index.message_start_time = chunk_messages == 0 ? 0 : chunk_start_time;
    index.message_end_time = chunk_messages == 0 ? 0 : chunk_end_time;
    index.chunk_start_offset = file_offset;
    index.records_size = chunk.size();

    ByteBuffer header;
    header.record_prefix(Opcode::kChunk, recording_detail::kChunkTimesSizeCrcBytes + 4 + kCompression.size() +
                                             8 + chunk.size());
    header.u64(index.message_start_time);
    header.u64(index.message_end_time);
    header.u64(chunk.size());  // uncompressed size
    header.u32(chunk_crc);
    header.string(kCompression);
    header.u64(chunk.size());  // records length
    emit(header, true);
    emit(chunk.data(), chunk.size(), false);
    data_section_crc = crc32_combine(data_section_crc, chunk_crc, chunk.size());
    index.chunk_length = file_offset - index.chunk_start_offset;

    // One MessageIndex per channel with messages in this chunk, by channel id, contiguous after the
    // chunk (rosbags infers per-channel counts from their spacing).
    ByteBuffer message_indexes;
    for (ChannelState& channel : channels) {
      if (channel.open_chunk_index.empty()) continue;
      index.message_index_offsets.emplace_back(channel.id, file_offset + message_indexes.size());
      message_indexes.record_prefix(Opcode::kMessageIndex,
                                    2 + 4 + channel.open_chunk_index.size() * recording_detail::kMessageIndexEntryBytes);
      message_indexes.u16(channel.id);
      message_indexes.u32(static_cast<std::uint32_t>(channel.open_chunk_index.size() *
                                                     recording_detail::kMessageIndexEntryBytes));
      for (const auto& [log_time, offset] : channel.open_chunk_index) {
        message_indexes.u64(log_time);
        message_indexes.u64(offset);
      }
      channel.open_chunk_index.clear();
    }
    index.message_index_length = message_indexes.size();
    emit(message_indexes, true);
    flush();

    chunk_indexes.push_back(std::move(index));
    chunk.clear();
    chunk_crc = 0;
    chunk_messages = 0;
  }

  std::string bag_information_yaml(std::size_t indent, const std::string& file_name) const {
    const std::string pad(indent, ' ');
    const std::uint64_t start = message_count == 0 ? 0 : first_log_time;
    const std::uint64_t duration = message_count == 0 ? 0 : last_log_time - first_log_time;
    std::string y;
    y += pad + "version: " + std::to_string(kRosbag2MetadataVersion) + "\n";
    y += pad + "storage_identifier: mcap\n";
    y += pad + "duration:\n" + pad + "  nanoseconds: " + std::to_string(duration) + "\n";
    y += pad + "starting_time:\n" + pad + "  nanoseconds_since_epoch: " + std::to_string(start) + "\n";
    y += pad + "message_count: " + std::to_string(message_count) + "\n";
    y += pad + "topics_with_message_count:" + std::string(channels.empty() ? " []" : "") + "\n";
    for (const ChannelState& channel : channels) {
      y += pad + "  - topic_metadata:\n";
      y += pad + "      name: " + yaml_quoted(channel.topic) + "\n";
      y += pad + "      type: " + yaml_quoted(channel.schema_name) + "\n";
      y += pad + "      serialization_format: cdr\n";
      y += pad + "      offered_qos_profiles:\n" + offered_qos_profiles_yaml(indent + 8) + "\n";
      y += pad + "      type_description_hash: \"\"\n";
      y += pad + "    message_count: " + std::to_string(channel.message_count) + "\n";
    }
    y += pad + "compression_format: \"\"\n";
    y += pad + "compression_mode: \"\"\n";
    y += pad + "relative_file_paths:\n" + pad + "  - " + yaml_quoted(file_name) + "\n";
    y += pad + "files:\n";
    y += pad + "  - path: " + yaml_quoted(file_name) + "\n";
    y += pad + "    starting_time:\n" + pad + "      nanoseconds_since_epoch: " + std::to_string(start) + "\n";
    y += pad + "    duration:\n" + pad + "      nanoseconds: " + std::to_string(duration) + "\n";
    y += pad + "    message_count: " + std::to_string(message_count) + "\n";
    y += pad + "custom_data: ~\n";
    y += pad + "ros_distro: \"\"\n";
    return y;
  }

  void finish() {
    close_chunk();
    const std::string file_name = std::filesystem::path(path).filename().string();

    // rosbag2 keeps its bag metadata in a Metadata record named "rosbag2"; its MCAP plugin reads
    // the format version from it (and so how to parse offered_qos_profiles).
    const std::uint64_t metadata_offset = file_offset;
    ByteBuffer metadata;
    {
      const std::size_t start = begin_record(metadata, Opcode::kMetadata);
      metadata.string("rosbag2");
      const std::size_t map_length_at = metadata.size();
      metadata.u32(0);
      metadata.string("serialized_metadata");
      metadata.string(bag_information_yaml(0, file_name));
      metadata.patch_u32(map_length_at, static_cast<std::uint32_t>(metadata.size() - map_length_at - 4));
      end_record(metadata, start);
    }
    emit(metadata, true);

    ByteBuffer data_end;
    data_end.record_prefix(Opcode::kDataEnd, recording_detail::kDataEndContentBytes);
    data_end.u32(data_section_crc);
    emit(data_end, false);

    // ---- summary: records grouped by opcode, each group indexed by a SummaryOffset ----
    const std::uint64_t summary_start = file_offset;
    ByteBuffer summary;
    struct Group {
      Opcode opcode;
      std::uint64_t start;
      std::uint64_t length;
    };
    std::vector<Group> groups;
    auto group = [&](Opcode opcode, auto&& append_records) {
      const std::size_t start = summary.size();
      append_records();
      if (summary.size() != start) groups.push_back({opcode, summary_start + start, summary.size() - start});
    };
    group(Opcode::kSchema, [&] {
      for (const SchemaState& schema : schemas) append_schema_record(summary, schema);
    });
    group(Opcode::kChannel, [&] {
      for (const ChannelState& channel : channels) append_channel_record(summary, channel);
    });
    group(Opcode::kStatistics, [&] {
      const std::size_t start = begin_record(summary, Opcode::kStatistics);
      summary.u64(message_count);
      summary.u16(static_cast<std::uint16_t>(schemas.size()));
      summary.u32(static_cast<std::uint32_t>(channels.size()));
      summary.u32(0);  // attachments
      summary.u32(1);  // metadata: "rosbag2"
      summary.u32(static_cast<std::uint32_t>(chunk_indexes.size()));
      summary.u64(message_count == 0 ? 0 : first_log_time);
      summary.u64(message_count == 0 ? 0 : last_log_time);
      summary.u32(static_cast<std::uint32_t>(channels.size() * (2 + 8)));
      for (const ChannelState& channel : channels) {
        summary.u16(channel.id);
        summary.u64(channel.message_count);
      }
      end_record(summary, start);
    });
    group(Opcode::kChunkIndex, [&] {
      for (const ChunkIndexState& index : chunk_indexes) {
        const std::size_t start = begin_record(summary, Opcode::kChunkIndex);
        summary.u64(index.message_start_time);
        summary.u64(index.message_end_time);
        summary.u64(index.chunk_start_offset);
        summary.u64(index.chunk_length);
        summary.u32(static_cast<std::uint32_t>(index.message_index_offsets.size() * (2 + 8)));
        for (const auto& [channel_id, offset] : index.message_index_offsets) {
          summary.u16(channel_id);
          summary.u64(offset);
        }
        summary.u64(index.message_index_length);
        summary.string(kCompression);
        summary.u64(index.records_size);  // compressed size
        summary.u64(index.records_size);  // uncompressed size
        end_record(summary, start);
      }
    });
    group(Opcode::kMetadataIndex, [&] {
      const std::size_t start = begin_record(summary, Opcode::kMetadataIndex);
      summary.u64(metadata_offset);
      summary.u64(metadata.size());
      summary.string("rosbag2");
      end_record(summary, start);
    });

    const std::uint64_t summary_offset_start = summary_start + summary.size();
    for (const Group& g : groups) {
      summary.record_prefix(Opcode::kSummaryOffset, recording_detail::kSummaryOffsetContentBytes);
      summary.u8(static_cast<std::uint8_t>(g.opcode));
      summary.u64(g.start);
      summary.u64(g.length);
    }

    // The summary CRC covers the summary and summary offset sections and the footer up to (not
    // including) the CRC field itself.
    summary.record_prefix(Opcode::kFooter, recording_detail::kFooterContentBytes);
    summary.u64(summary_start);
    summary.u64(summary_offset_start);
    summary.u32(crc32(summary.data(), summary.size()));
    summary.append(recording_detail::kMagic.data(), recording_detail::kMagic.size());
    emit(summary, false);
    flush();

    std::FILE* raw = file.release();
    if (std::fclose(raw) != 0) fail_io("cannot close");

    if (options.write_rosbag2_metadata) write_metadata_yaml(file_name);
  }

  void write_metadata_yaml(const std::string& file_name) {
    const std::filesystem::path yaml_path = std::filesystem::path(path).parent_path() / "metadata.yaml";
    std::ofstream out(yaml_path, std::ios::binary | std::ios::trunc);
    out << "rosbag2_bagfile_information:\n" << bag_information_yaml(2, file_name);
    out.close();
    if (!out) {
      failed = true;
      throw std::runtime_error("recording " + path + ": cannot write " + yaml_path.string());
    }
  }
};

RecordingWriter::RecordingWriter(const std::string& path, RecordingWriterOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->options = options;
  impl_->file.reset(std::fopen(path.c_str(), "wb"));
  if (!impl_->file)
    throw std::runtime_error("recording " + path + ": cannot create: " + std::string(std::strerror(errno)));
  impl_->chunk.reserve(std::min<std::size_t>(options.chunk_bytes, std::size_t{64} << 20) + (std::size_t{64} << 10));

  ByteBuffer header;
  header.append(recording_detail::kMagic.data(), recording_detail::kMagic.size());
  const std::string library = std::string("rsrio ") + kVersion;
  header.record_prefix(Opcode::kHeader, 4 + kProfile.size() + 4 + library.size());
  header.string(kProfile);
  header.string(library);
  impl_->emit(header, true);  // the data-section CRC starts at the magic, as MCAP readers compute it
  impl_->flush();
}

RecordingWriter::~RecordingWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
  }
}

void RecordingWriter::write(const std::string& topic, const rsrio_msgs::msg::RadarFrame& msg, std::uint64_t log_time_ns) {
  impl_->write_message(topic, msg, log_time_ns);
}
void RecordingWriter::write(const std::string& topic, const sensor_msgs::msg::Imu& msg, std::uint64_t log_time_ns) {
  impl_->write_message(topic, msg, log_time_ns);
}
void RecordingWriter::write(const std::string& topic, const nav_msgs::msg::Odometry& msg, std::uint64_t log_time_ns) {
  impl_->write_message(topic, msg, log_time_ns);
}
void RecordingWriter::write(const std::string& topic, const sensor_msgs::msg::PointCloud2& msg,
                            std::uint64_t log_time_ns) {
  impl_->write_message(topic, msg, log_time_ns);
}
void RecordingWriter::write(const std::string& topic, const geometry_msgs::msg::PoseStamped& msg,
                            std::uint64_t log_time_ns) {
  impl_->write_message(topic, msg, log_time_ns);
}

void RecordingWriter::close() {
  if (!impl_ || impl_->closed) return;
  impl_->closed = true;  // also after a failure: a second close() must not write a second summary
  if (impl_->failed)
    throw std::runtime_error("recording " + impl_->path +
                             ": not finished because an earlier write failed; it is readable up to the last "
                             "complete chunk");
  impl_->finish();
}

}  // namespace rsrio
