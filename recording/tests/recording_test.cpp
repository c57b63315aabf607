// Recording writer and reader: round trips, crash/truncation behaviour, corruption detection, the
// file layout other MCAP readers rely on, and the radar configuration's message form.
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>

#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_string.hpp>

#include "crc32.hpp"
#include "recording_test_support.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/recording/recording.hpp"

using namespace rsrio;
using namespace rsrio::test;
using Catch::Matchers::ContainsSubstring;

namespace {

template <typename Message>
Message decoded(const RecordedMessage& recorded) {
  Message out;
  REQUIRE(decode(recorded, out));
  return out;
}

std::uint64_t stamp_ns(const std_msgs::msg::Header& header) {
  return static_cast<std::uint64_t>(header.stamp().sec()) * 1'000'000'000ull + header.stamp().nanosec();
}

// A small recording of every type, several chunks of a few hundred bytes each.
std::size_t write_small_recording(const std::string& path) {
  RecordingWriterOptions options;
  options.chunk_bytes = 600;
  RecordingWriter writer(path, options);
  std::size_t count = 0;
  for (int i = 0; i < 6; ++i) {
    writer.write(topics::kImu, make_imu(i), kT0 + 10 + 2'500'000ull * static_cast<std::uint64_t>(i));
    ++count;
    if (i % 2 == 0) {
      writer.write(topics::kOdometry, make_odometry(i), kT0 + 20 + 100'000'000ull * static_cast<std::uint64_t>(i));
      writer.write("/rsrio/pose", make_pose(i), kT0 + 30 + 50'000'000ull * static_cast<std::uint64_t>(i));
      count += 2;
    }
    if (i % 3 == 0) {
      writer.write(topics::kRadarPoints, make_point_cloud(i, 3), kT0 + 40 + static_cast<std::uint64_t>(i));
      writer.write(topics::kRadarRaw, make_radar_frame(i, 64), kT0 + 50 + static_cast<std::uint64_t>(i));
      count += 2;
    }
  }
  writer.close();
  return count;
}

// Messages of `full` in chunks that end at or before `size` bytes: what a reader of the file cut
// at `size` must return.
std::size_t messages_before(const std::vector<RecordSpan>& records, std::size_t size) {
  std::size_t count = 0;
  for (const RecordSpan& r : records)
    if (r.opcode == 0x06 && r.end <= size) count += r.chunk_messages;
  return count;
}

void require_same_message(const RecordedMessage& a, const RecordedMessage& b) {
  REQUIRE(a.topic == b.topic);
  REQUIRE(a.schema_name == b.schema_name);
  REQUIRE(a.log_time_ns == b.log_time_ns);
  REQUIRE(a.publish_time_ns == b.publish_time_ns);
  REQUIRE(a.sequence == b.sequence);
  REQUIRE(a.cdr == b.cdr);
}

// Reads a truncated copy and checks it is a clean prefix with damage at or before the cut.
void check_truncated(const std::string& path, std::size_t size, const std::vector<RecordedMessage>& full,
                     const std::vector<RecordSpan>& records) {
  INFO("file cut at " << size << " bytes");
  ReadResult cut;
  REQUIRE_NOTHROW(cut = read_all(path));  // even an empty file: a recording that never got its magic out
  REQUIRE(cut.damage.has_value());
  REQUIRE(cut.damage->offset <= size);
  REQUIRE(cut.damage->messages_read == cut.messages.size());
  REQUIRE(cut.messages.size() == messages_before(records, size));
  for (std::size_t k = 0; k < cut.messages.size(); ++k) require_same_message(cut.messages[k], full[k]);
  REQUIRE_FALSE(cut.damage->reason.empty());
}

}  // namespace

TEST_CASE("recording: every message type round-trips field for field, raw frames across several chunks", "[recording]") {
  ScratchDir dir("roundtrip");
  const std::string path = dir.file("roundtrip.mcap");
  constexpr std::size_t kAdcBytes = 3 * 1024 * 1024 + 12345;  // a multi-MB raw frame

  std::vector<rsrio_msgs::msg::RadarFrame> frames;
  std::vector<sensor_msgs::msg::Imu> imus;
  std::vector<nav_msgs::msg::Odometry> odometries;
  std::vector<sensor_msgs::msg::PointCloud2> clouds;
  std::vector<geometry_msgs::msg::PoseStamped> poses;
  {
    RecordingWriter writer(path);  // default 4 MiB chunks: a chunk closes after every second frame
    for (int i = 0; i < 5; ++i) {
      frames.push_back(make_radar_frame(i, kAdcBytes));
      writer.write(topics::kRadarRaw, frames.back(), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i) + 7);
      for (int k = 0; k < 4; ++k) {
        imus.push_back(make_imu(4 * i + k));
        writer.write(topics::kImu, imus.back(), kT0 + 2'500'000ull * static_cast<std::uint64_t>(4 * i + k) + 3);
      }
      odometries.push_back(make_odometry(i));
      writer.write(topics::kGroundTruth, odometries.back(), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i) + 9);
      clouds.push_back(make_point_cloud(i, 50 + i));
      writer.write(topics::kRadarPoints, clouds.back(), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i) + 11);
      poses.push_back(make_pose(i));
      writer.write("/rsrio/pose", poses.back(), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i) + 13);
    }
    // destructor closes
  }

  const ReadResult result = read_all(path);
  REQUIRE_FALSE(result.damage.has_value());
  REQUIRE(result.profile == "ros2");
  REQUIRE(result.messages.size() == 5 * 8);

  const auto records = walk_records(file_bytes(path));
  const auto chunks = std::count_if(records.begin(), records.end(), [](const RecordSpan& r) { return r.opcode == 0x06; });
  CHECK(chunks >= 3);

  std::size_t frame = 0, imu = 0, odometry = 0, cloud = 0, pose = 0;
  for (const RecordedMessage& m : result.messages) {
    REQUIRE(m.cdr.size() >= 4);
    REQUIRE(m.cdr[0] == 0x00);  // CDR little-endian encapsulation, as ROS 2 stores it
    REQUIRE(m.cdr[1] == 0x01);
    REQUIRE(m.cdr[2] == 0x00);
    REQUIRE(m.cdr[3] == 0x00);
    if (m.topic == topics::kRadarRaw) {
      REQUIRE(m.schema_name == "rsrio_msgs/msg/RadarFrame");
      REQUIRE(m.sequence == frame);
      const auto out = decoded<rsrio_msgs::msg::RadarFrame>(m);
      REQUIRE(out == frames[frame]);
      REQUIRE(out.adc().size() == kAdcBytes);
      REQUIRE(m.publish_time_ns == stamp_ns(frames[frame].header()));
      REQUIRE(m.log_time_ns == kT0 + 100'000'000ull * frame + 7);
      ++frame;
    } else if (m.topic == topics::kImu) {
      REQUIRE(m.schema_name == "sensor_msgs/msg/Imu");
      REQUIRE(m.sequence == imu);
      REQUIRE(decoded<sensor_msgs::msg::Imu>(m) == imus[imu]);
      ++imu;
    } else if (m.topic == topics::kGroundTruth) {
      REQUIRE(m.schema_name == "nav_msgs/msg/Odometry");
      REQUIRE(decoded<nav_msgs::msg::Odometry>(m) == odometries[odometry]);
      ++odometry;
    } else if (m.topic == topics::kRadarPoints) {
      REQUIRE(m.schema_name == "sensor_msgs/msg/PointCloud2");
      REQUIRE(decoded<sensor_msgs::msg::PointCloud2>(m) == clouds[cloud]);
      ++cloud;
    } else {
      REQUIRE(m.topic == "/rsrio/pose");
      REQUIRE(m.schema_name == "geometry_msgs/msg/PoseStamped");
      REQUIRE(decoded<geometry_msgs::msg::PoseStamped>(m) == poses[pose]);
      ++pose;
    }
  }
  REQUIRE((frame == 5 && imu == 20 && odometry == 5 && cloud == 5 && pose == 5));

  // The file order is the write order.
  REQUIRE(result.messages[0].topic == topics::kRadarRaw);
  REQUIRE(result.messages[1].topic == topics::kImu);
  REQUIRE(result.messages[7].topic == "/rsrio/pose");

  // decode() refuses a message of another schema instead of misreading it.
  sensor_msgs::msg::Imu wrong;
  REQUIRE_FALSE(decode(result.messages[0], wrong));
}

TEST_CASE("recording: a zero header stamp makes the publish time the log time", "[recording]") {
  ScratchDir dir("stamp");
  const std::string path = dir.file("stamp.mcap");
  {
    RecordingWriter writer(path);
    writer.write(topics::kOdometry, nav_msgs::msg::Odometry{}, kT0 + 42);
  }
  const ReadResult result = read_all(path);
  REQUIRE(result.messages.size() == 1);
  REQUIRE(result.messages[0].publish_time_ns == kT0 + 42);
  REQUIRE(result.messages[0].sequence == 0);
}

TEST_CASE("recording: an empty recording is a valid file with no messages", "[recording]") {
  ScratchDir dir("empty");
  const std::string path = dir.file("empty.mcap");
  RecordingWriter(path).close();
  const ReadResult result = read_all(path);
  REQUIRE(result.messages.empty());
  REQUIRE_FALSE(result.damage.has_value());
  REQUIRE(result.profile == "ros2");
}

TEST_CASE("recording: the writer keeps one type per topic and refuses writes after close", "[recording]") {
  ScratchDir dir("misuse");
  RecordingWriter writer(dir.file("misuse.mcap"));
  writer.write(topics::kImu, make_imu(0), kT0);
  REQUIRE_THROWS_AS(writer.write(topics::kImu, make_odometry(0), kT0), std::invalid_argument);
  writer.write(topics::kImu, make_imu(1), kT0 + 1);  // still usable
  writer.close();
  writer.close();  // idempotent
  REQUIRE_THROWS_AS(writer.write(topics::kImu, make_imu(2), kT0 + 2), std::logic_error);
  REQUIRE(read_all(dir.file("misuse.mcap")).messages.size() == 2);
}

TEST_CASE("recording: a writer that cannot create its file throws naming the path", "[recording]") {
  const std::string path = "/nonexistent-dir-rsrio/recording.mcap";
  REQUIRE_THROWS_WITH(RecordingWriter(path), ContainsSubstring(path));
}

TEST_CASE("recording: closed chunks reach the file before close(): a crash loses only the open chunk", "[recording]") {
  ScratchDir dir("crash");
  const std::string path = dir.file("crash.mcap");
  RecordingWriterOptions options;
  options.chunk_bytes = 2000;  // an Imu record is ~350 bytes: three more cannot fill a new chunk
  RecordingWriter writer(path, options);
  const auto header_bytes = std::filesystem::file_size(path);  // the header is on disk at once
  REQUIRE(header_bytes > 8);

  int written = 0;
  while (std::filesystem::file_size(path) == header_bytes) {
    REQUIRE(written < 100);
    writer.write(topics::kImu, make_imu(written), kT0 + static_cast<std::uint64_t>(written));
    ++written;
  }
  const int flushed = written;  // the first chunk closed with this message and went to the OS
  for (int k = 0; k < 3; ++k, ++written)
    writer.write(topics::kImu, make_imu(written), kT0 + static_cast<std::uint64_t>(written));

  // The writer is still open, as if the process died now: read what is on disk.
  const ReadResult on_disk = read_all(path);
  REQUIRE(on_disk.damage.has_value());
  REQUIRE_THAT(on_disk.damage->reason, ContainsSubstring("without a data end record"));
  REQUIRE(on_disk.messages.size() == static_cast<std::size_t>(flushed));
  for (std::size_t k = 0; k < on_disk.messages.size(); ++k) REQUIRE(on_disk.messages[k].sequence == k);
  writer.close();
  REQUIRE(read_all(path).messages.size() == static_cast<std::size_t>(written));
}

TEST_CASE("recording: truncation at every byte of a small recording reads a clean prefix", "[recording][truncation]") {
  ScratchDir dir("truncate_small");
  const std::string path = dir.file("full.mcap");
  const std::size_t count = write_small_recording(path);
  const std::vector<std::uint8_t> bytes = file_bytes(path);
  const auto records = walk_records(bytes);
  const ReadResult full = read_all(path);
  REQUIRE_FALSE(full.damage.has_value());
  REQUIRE(full.messages.size() == count);
  REQUIRE(std::count_if(records.begin(), records.end(), [](const RecordSpan& r) { return r.opcode == 0x06; }) >= 5);

  const std::string cut_path = dir.file("cut.mcap");
  for (std::size_t size = 0; size < bytes.size(); ++size) {
    write_bytes(cut_path, bytes.data(), size);
    check_truncated(cut_path, size, full.messages, records);
  }
}

TEST_CASE("recording: truncation at random offsets of a recording with raw frames reads a clean prefix",
          "[recording][truncation]") {
  ScratchDir dir("truncate_large");
  const std::string path = dir.file("full.mcap");
  {
    RecordingWriterOptions options;
    options.chunk_bytes = 512 * 1024;
    RecordingWriter writer(path, options);
    for (int i = 0; i < 6; ++i) {
      writer.write(topics::kRadarRaw, make_radar_frame(i, 700'000), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i));
      for (int k = 0; k < 40; ++k)
        writer.write(topics::kImu, make_imu(40 * i + k), kT0 + 2'500'000ull * static_cast<std::uint64_t>(40 * i + k));
    }
  }
  const std::vector<std::uint8_t> bytes = file_bytes(path);
  const auto records = walk_records(bytes);
  const ReadResult full = read_all(path);
  REQUIRE_FALSE(full.damage.has_value());
  REQUIRE(full.messages.size() == 6 * 41);

  // Random cuts, plus cuts right around every record boundary (the interesting places).
  std::set<std::size_t> cuts;
  std::mt19937_64 random(20240611);
  while (cuts.size() < 60) cuts.insert(static_cast<std::size_t>(random() % bytes.size()));
  for (const RecordSpan& r : records)
    for (std::size_t delta : {0, 1, 8, 9, 10, 49, 50})
      if (r.offset + delta < bytes.size()) cuts.insert(r.offset + delta);

  // Cut one copy shorter and shorter instead of rewriting megabytes per cut.
  const std::string cut_path = dir.file("cut.mcap");
  std::filesystem::copy_file(path, cut_path);
  for (auto it = cuts.rbegin(); it != cuts.rend(); ++it) {
    std::filesystem::resize_file(cut_path, *it);
    check_truncated(cut_path, *it, full.messages, records);
  }
}

TEST_CASE("recording: a flipped byte inside a chunk is detected as a CRC mismatch", "[recording][corruption]") {
  ScratchDir dir("flip");
  const std::string path = dir.file("flip.mcap");
  write_small_recording(path);
  const std::vector<std::uint8_t> bytes = file_bytes(path);
  const auto records = walk_records(bytes);
  const ReadResult full = read_all(path);

  std::vector<RecordSpan> chunks;
  for (const RecordSpan& r : records)
    if (r.opcode == 0x06) chunks.push_back(r);
  REQUIRE(chunks.size() >= 3);

  for (std::size_t victim = 0; victim < 3; ++victim) {
    const RecordSpan& chunk = chunks[victim];
    for (std::size_t at : {chunk.chunk_records_offset, (chunk.chunk_records_offset + chunk.end) / 2, chunk.end - 1}) {
      INFO("chunk " << victim << ", byte " << at);
      std::vector<std::uint8_t> corrupt = bytes;
      corrupt[at] ^= 0x10;
      const std::string corrupt_path = dir.file("corrupt.mcap");
      write_bytes(corrupt_path, corrupt.data(), corrupt.size());
      const ReadResult result = read_all(corrupt_path);
      REQUIRE(result.damage.has_value());
      REQUIRE_THAT(result.damage->reason, ContainsSubstring("chunk CRC mismatch"));
      REQUIRE(result.damage->offset == chunk.offset);
      REQUIRE(result.messages.size() == messages_before(records, chunk.offset));
      for (std::size_t k = 0; k < result.messages.size(); ++k) require_same_message(result.messages[k], full.messages[k]);
    }
  }
}

TEST_CASE("recording: corrupt lengths stop the reader without huge allocations", "[recording][corruption]") {
  ScratchDir dir("lengths");
  const std::string path = dir.file("lengths.mcap");
  write_small_recording(path);
  const std::vector<std::uint8_t> bytes = file_bytes(path);
  const auto records = walk_records(bytes);
  const RecordSpan& first_chunk = *std::find_if(records.begin(), records.end(), [](const RecordSpan& r) { return r.opcode == 0x06; });

  auto read_with = [&](std::size_t at, std::uint64_t value, int width) {
    std::vector<std::uint8_t> corrupt = bytes;
    for (int i = 0; i < width; ++i) corrupt[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(value >> (8 * i));
    const std::string corrupt_path = dir.file("corrupt.mcap");
    write_bytes(corrupt_path, corrupt.data(), corrupt.size());
    return read_all(corrupt_path);
  };

  SECTION("a record length far beyond the file") {
    const ReadResult r = read_with(first_chunk.offset + 1, std::uint64_t{1} << 62, 8);
    REQUIRE(r.damage.has_value());
    REQUIRE(r.damage->offset == first_chunk.offset);
    REQUIRE_THAT(r.damage->reason, ContainsSubstring("file ends inside a chunk record"));
    REQUIRE(r.messages.empty());
  }
  SECTION("the maximum record length") {
    const ReadResult r = read_with(first_chunk.offset + 1, std::numeric_limits<std::uint64_t>::max(), 8);
    REQUIRE(r.damage.has_value());
    REQUIRE(r.messages.empty());
  }
  SECTION("a chunk's records length beyond its record") {
    const ReadResult r = read_with(first_chunk.chunk_records_offset - 8, std::uint64_t{1} << 40, 8);
    REQUIRE(r.damage.has_value());
    REQUIRE_THAT(r.damage->reason, ContainsSubstring("malformed chunk"));
  }
  SECTION("a chunk compression name length beyond its record") {
    const ReadResult r = read_with(first_chunk.offset + 9 + 28, 0xFFFFFFF0u, 4);
    REQUIRE(r.damage.has_value());
    REQUIRE_THAT(r.damage->reason, ContainsSubstring("malformed chunk"));
  }
  SECTION("a zero-filled tail") {
    std::vector<std::uint8_t> zeros = bytes;
    std::fill(zeros.begin() + static_cast<std::ptrdiff_t>(first_chunk.end), zeros.end(), 0);
    const std::string zero_path = dir.file("zeros.mcap");
    write_bytes(zero_path, zeros.data(), zeros.size());
    const ReadResult r = read_all(zero_path);
    REQUIRE(r.damage.has_value());
    REQUIRE(r.damage->offset == first_chunk.end);
    REQUIRE(r.messages.size() == first_chunk.chunk_messages);
  }
}

TEST_CASE("recording: a file that is not MCAP makes the reader throw naming the path", "[recording]") {
  ScratchDir dir("not_mcap");
  const std::string text_path = dir.file("notes.txt");
  {
    std::ofstream out(text_path);
    out << "this is not a recording\n";
  }
  REQUIRE_THROWS_AS(RecordingReader(text_path), std::runtime_error);
  REQUIRE_THROWS_WITH(RecordingReader(text_path), ContainsSubstring(text_path));
  REQUIRE_THROWS_WITH(RecordingReader(dir.file("missing.mcap")), ContainsSubstring(dir.file("missing.mcap")));

  // A one-byte file that is not the start of the magic is not a recording either.
  const std::string one_byte = dir.file("one.bin");
  write_bytes(one_byte, reinterpret_cast<const std::uint8_t*>("M"), 1);
  REQUIRE_THROWS_WITH(RecordingReader(one_byte), ContainsSubstring("not an MCAP file"));
}

TEST_CASE("recording: damage is reported in one line a person can read", "[recording]") {
  RecordingDamage damage{1234, "chunk CRC mismatch", 17};
  REQUIRE(damage.message() == "recording damaged at byte 1234: chunk CRC mismatch (17 messages read before it)");
}

TEST_CASE("recording: the file layout is what index-based MCAP readers expect", "[recording][layout]") {
  ScratchDir dir("layout");
  const std::string path = dir.file("layout.mcap");
  const std::size_t count = write_small_recording(path);
  const std::vector<std::uint8_t> bytes = file_bytes(path);
  const auto records = walk_records(bytes);
  using recording_detail::crc32;

  REQUIRE(std::equal(bytes.end() - 8, bytes.end(), bytes.begin()));  // closing magic
  REQUIRE(records.front().opcode == 0x01);
  REQUIRE(records.back().opcode == 0x02);
  REQUIRE(records.back().end + 8 == bytes.size());

  // Data section: chunks, each followed by its message indexes, then metadata and data end.
  const auto data_end = std::find_if(records.begin(), records.end(), [](const RecordSpan& r) { return r.opcode == 0x0F; });
  REQUIRE(data_end != records.end());
  for (auto it = records.begin() + 1; it != data_end; ++it) REQUIRE((it->opcode == 0x06 || it->opcode == 0x07 || it->opcode == 0x0C));
  REQUIRE(le(bytes, data_end->offset + 9, 4) == crc32(bytes.data(), data_end->offset));

  // Chunk CRCs.
  for (const RecordSpan& r : records) {
    if (r.opcode != 0x06) continue;
    REQUIRE(le(bytes, r.offset + 9 + 28, 4) == 0);  // compression ""
    const std::size_t records_size = static_cast<std::size_t>(le(bytes, r.chunk_records_offset - 8, 8));
    REQUIRE(le(bytes, r.offset + 9 + 24, 4) == crc32(bytes.data() + r.chunk_records_offset, records_size));
  }

  // Footer -> summary; summary CRC; summary offsets point at their groups.
  const std::size_t footer = records.back().offset;
  const std::size_t summary_start = static_cast<std::size_t>(le(bytes, footer + 9, 8));
  const std::size_t summary_offset_start = static_cast<std::size_t>(le(bytes, footer + 17, 8));
  REQUIRE(summary_start == data_end->end);
  REQUIRE(le(bytes, footer + 25, 4) == crc32(bytes.data() + summary_start, footer + 25 - summary_start));
  std::set<std::uint8_t> grouped;
  for (const RecordSpan& r : records) {
    if (r.offset < summary_offset_start || r.opcode != 0x0E) continue;
    const std::uint8_t group = bytes[r.offset + 9];
    const std::size_t start = static_cast<std::size_t>(le(bytes, r.offset + 10, 8));
    const std::size_t length = static_cast<std::size_t>(le(bytes, r.offset + 18, 8));
    grouped.insert(group);
    for (std::size_t at = start; at < start + length; at += 9 + static_cast<std::size_t>(le(bytes, at + 1, 8)))
      REQUIRE(bytes[at] == group);
  }
  REQUIRE(grouped == std::set<std::uint8_t>{0x03, 0x04, 0x08, 0x0B, 0x0D});

  // Statistics count every message; chunk indexes point at chunks and their message indexes.
  std::size_t chunk_indexes = 0;
  for (const RecordSpan& r : records) {
    if (r.offset < summary_start) continue;
    if (r.opcode == 0x0B) REQUIRE(le(bytes, r.offset + 9, 8) == count);
    if (r.opcode == 0x04) REQUIRE(le(bytes, r.offset + 9, 2) >= 1);  // channel ids start at 1
    if (r.opcode != 0x08) continue;
    ++chunk_indexes;
    const std::size_t chunk_offset = static_cast<std::size_t>(le(bytes, r.offset + 9 + 16, 8));
    REQUIRE(bytes[chunk_offset] == 0x06);
    const std::size_t map_bytes = static_cast<std::size_t>(le(bytes, r.offset + 9 + 32, 4));
    for (std::size_t at = r.offset + 9 + 36; at < r.offset + 9 + 36 + map_bytes; at += 10)
      REQUIRE(bytes[static_cast<std::size_t>(le(bytes, at + 2, 8))] == 0x07);
  }
  REQUIRE(chunk_indexes ==
          static_cast<std::size_t>(std::count_if(records.begin(), records.end(),
                                                 [](const RecordSpan& r) { return r.opcode == 0x06; })));
}

TEST_CASE("recording: decode() rejects corrupt CDR without crashing or allocating what it claims", "[recording][corruption]") {
  ScratchDir dir("cdr");
  const std::string path = dir.file("cdr.mcap");
  {
    RecordingWriter writer(path);
    writer.write(topics::kRadarPoints, make_point_cloud(1, 4), kT0);
    writer.write(topics::kRadarRaw, make_radar_frame(1, 1000), kT0 + 1);
  }
  const ReadResult result = read_all(path);
  REQUIRE(result.messages.size() == 2);
  RecordedMessage cloud = result.messages[0];
  sensor_msgs::msg::PointCloud2 out;

  RecordedMessage xcdr2 = cloud;
  xcdr2.cdr[1] = 0x07;  // XCDR2 little-endian: not what ROS 2 stores
  REQUIRE_FALSE(decode(xcdr2, out));

  RecordedMessage too_short = cloud;
  too_short.cdr.resize(too_short.cdr.size() / 2);
  REQUIRE_FALSE(decode(too_short, out));

  // Fields sequence length (after the header: stamp 8, frame_id "radar" 4+6 -> pad, height, width)
  // set to ~4 billion: must fail on the bytes present, not try to allocate the elements.
  RecordedMessage huge = cloud;
  const std::size_t fields_length_at = 4 + 8 + 4 + 6 + 2 /*align 4*/ + 4 + 4;
  REQUIRE(huge.cdr[fields_length_at] == 5);  // five PointFields
  huge.cdr[fields_length_at + 0] = 0xF0;
  huge.cdr[fields_length_at + 1] = 0xFF;
  huge.cdr[fields_length_at + 2] = 0xFF;
  huge.cdr[fields_length_at + 3] = 0xFF;
  REQUIRE_FALSE(decode(huge, out));

  // Random garbage behind a valid header, for every type: false or true, never a crash.
  std::mt19937 random(7);
  for (int round = 0; round < 200; ++round) {
    RecordedMessage garbage = result.messages[round % 2];
    for (std::size_t k = 4; k < garbage.cdr.size(); ++k)
      if (random() % 8 == 0) garbage.cdr[k] = static_cast<std::uint8_t>(random());
    rsrio_msgs::msg::RadarFrame frame;
    static_cast<void>(decode(garbage, out));
    static_cast<void>(decode(garbage, frame));
  }
}

TEST_CASE("recording: radar configurations survive their message form", "[recording][radar_config]") {
  for (const auto name : radar_presets()) {
    RadarConfig config = radar_preset(name);
    const RadarDerived derived = derive(config);
    const std::size_t channels = config.array.tx_azimuth.size() * config.array.rx_azimuth.size();
    for (std::size_t k = 0; k < channels; ++k) config.calibration.gain.emplace_back(1.0 + 0.01 * k, -0.02 * k);
    config.calibration.frequency_offset_hz.assign(channels, 12.5);
    config.capture.offset_binary = true;

    const rsrio_msgs::msg::RadarConfig msg = to_msg(config);
    const RadarConfig back = from_msg(msg);
    REQUIRE(to_msg(back) == msg);
    REQUIRE(back.preset == config.preset);
    REQUIRE(back.chirp.samples_per_chirp == config.chirp.samples_per_chirp);
    REQUIRE(back.tx_order == config.tx_order);
    REQUIRE(back.array.rx_azimuth == config.array.rx_azimuth);
    REQUIRE(back.calibration.gain == config.calibration.gain);
    REQUIRE(back.calibration.frequency_offset_hz == config.calibration.frequency_offset_hz);
    REQUIRE(back.capture.format == config.capture.format);
    REQUIRE(back.capture.lvds_lanes == config.capture.lvds_lanes);
    REQUIRE(derive(back).frame_bytes == derived.frame_bytes);
  }
}

TEST_CASE("recording: a corrupt radar configuration in a recording is rejected with ConfigError", "[recording][radar_config]") {
  const rsrio_msgs::msg::RadarConfig good = to_msg(radar_preset("xwr1843"));
  auto rejects = [](const rsrio_msgs::msg::RadarConfig& msg, const std::string& key) {
    try {
      static_cast<void>(from_msg(msg));
      FAIL("accepted a corrupt configuration (" << key << ")");
    } catch (const ConfigError& e) {
      CHECK(e.file() == "<recording>");
      CHECK(e.key() == key);
    }
  };
  {
    auto msg = good;
    msg.samples_per_chirp(0xFFFFFFFFu);
    rejects(msg, "radar.chirp.samples_per_chirp");
  }
  {
    auto msg = good;
    msg.start_frequency_ghz(std::numeric_limits<double>::quiet_NaN());
    rejects(msg, "radar.chirp.start_frequency_ghz");
  }
  {
    auto msg = good;
    msg.tx_order({0, 2, 7});  // TX 7 does not exist on a 3-TX array: only validate() knows
    rejects(msg, "radar.tx_order");
  }
  {
    auto msg = good;
    msg.calibration_gain_re({1.0, 1.0});
    msg.calibration_gain_im({0.0});
    rejects(msg, "radar.calibration.gain_im");
  }
  {
    auto msg = good;
    msg.capture_format("pcap");
    rejects(msg, "radar.capture.format");
  }
  {
    auto msg = good;
    msg.lvds_lanes(3);
    rejects(msg, "radar.capture.lvds_lanes");
  }
  {
    auto msg = good;
    msg.frame_period_ms(1.0);  // shorter than the chirps of one frame
    rejects(msg, "radar.frame_period_ms");
  }
}
