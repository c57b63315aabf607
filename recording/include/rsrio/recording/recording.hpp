// Recordings: rosbag2-compatible MCAP files (profile "ros2", CDR messages serialised with Fast
// CDR through the fastddsgen types, "ros2msg" schemas embedded, chunked with CRCs, summary and
// index), written and read by our own implementation of the MCAP format.
//
// A reader goes through the data section record by record, so a file cut at any byte (a crash, a
// full disk) is read up to the damage, and damage() tells where and why it stopped.
//
// Who opens what:
//  * the bare .mcap is meant for Foxglove, the MCAP tools and `ros2 bag info/play` (the rosbag2
//    MCAP plugin rebuilds the bag metadata from the summary and from the "rosbag2" metadata record
//    we write). That follows from the spec and rosbag2's sources; no ROS is in the build root, so
//    the tests check the layout with their own walker and with zlib, not with those tools;
//  * python3-rosbags (0.10.9, Debian 13) opens only rosbag2 bag *directories* (its Reader and
//    AnyReader require `metadata.yaml`; a bare .mcap makes AnyReader try rosbag1). Set
//    RecordingWriterOptions::write_rosbag2_metadata and write `<dir>/<name>_0.mcap`: close() then
//    writes `<dir>/metadata.yaml` (rosbag2 format version 9) and `<dir>` is a rosbag2 bag that
//    `rosbags.highlevel.AnyReader([Path(dir)])` reads, decoding with the embedded schemas.
//
// Layout written: magic, Header (profile "ros2", library "rsrio <version>"), uncompressed Chunks
// (Schema and Channel records precede a channel's first message inside the chunk; CRC filled),
// after each chunk one MessageIndex per channel in it, a Metadata record "rosbag2", DataEnd (data
// section CRC), summary (Schemas, Channels, Statistics, ChunkIndexes, MetadataIndex), one
// SummaryOffset per summary group, Footer (summary CRC), magic.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geometry_msgs/msg/PoseStamped.hpp"
#include "nav_msgs/msg/Odometry.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio_msgs/msg/RadarFrame.hpp"
#include "sensor_msgs/msg/Imu.hpp"
#include "sensor_msgs/msg/PointCloud2.hpp"

namespace rsrio {

/// The topics rsrio records (ROS 2 names).
namespace topics {
inline constexpr const char* kRadarRaw = "/radar/raw";         // rsrio_msgs/msg/RadarFrame
inline constexpr const char* kImu = "/imu";                    // sensor_msgs/msg/Imu
inline constexpr const char* kGroundTruth = "/ground_truth";   // nav_msgs/msg/Odometry
inline constexpr const char* kRadarPoints = "/radar/points";   // sensor_msgs/msg/PointCloud2
inline constexpr const char* kOdometry = "/rsrio/odom";        // nav_msgs/msg/Odometry
}  // namespace topics

struct RecordingWriterOptions {
  /// A chunk is closed, written and flushed when its messages reach this size; a crash loses at
  /// most the open chunk.
  std::size_t chunk_bytes = 4 * 1024 * 1024;
  /// At close(), also write `metadata.yaml` into the directory holding the file, which makes that
  /// directory a rosbag2 bag with this file as its only storage file (python3-rosbags needs it;
  /// see the top of this file). The directory must hold this one recording only.
  bool write_rosbag2_metadata = false;
};

class RecordingWriter {
 public:
  /// Creates (truncates) `path`. Throws std::runtime_error naming the path on failure.
  explicit RecordingWriter(const std::string& path, RecordingWriterOptions options = {});
  ~RecordingWriter();  // close()s; never throws
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  // One channel per topic, made on its first message. log_time_ns: when the message was
  // received/made (ns since the epoch); publish time = the message's header stamp (the log time
  // when the stamp is zero or negative). The MCAP sequence number counts the channel's messages
  // from 0. log_time_ns must be > 0: MCAP chunk and statistics times use 0 for "no messages", and
  // rosbags skips chunks whose earliest log time is 0. Throws std::invalid_argument when the topic
  // already carries another type, std::runtime_error naming the path on an I/O error, and
  // std::logic_error after close().
  void write(const std::string& topic, const rsrio_msgs::msg::RadarFrame& msg, std::uint64_t log_time_ns);
  void write(const std::string& topic, const sensor_msgs::msg::Imu& msg, std::uint64_t log_time_ns);
  void write(const std::string& topic, const nav_msgs::msg::Odometry& msg, std::uint64_t log_time_ns);
  void write(const std::string& topic, const sensor_msgs::msg::PointCloud2& msg, std::uint64_t log_time_ns);
  void write(const std::string& topic, const geometry_msgs::msg::PoseStamped& msg, std::uint64_t log_time_ns);

  /// Writes the open chunk, the summary and the footer. Throws on an I/O error. Idempotent.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One message as stored: topic, schema ("pkg/msg/Type"), times and its CDR bytes (with the
/// 4-byte encapsulation header).
struct RecordedMessage {
  std::string topic;
  std::string schema_name;
  std::uint64_t log_time_ns = 0;
  std::uint64_t publish_time_ns = 0;
  std::uint32_t sequence = 0;
  std::vector<std::uint8_t> cdr;
};

/// Where and why reading stopped before the end of a file.
struct RecordingDamage {
  std::uint64_t offset = 0;   // byte offset of the first record that could not be read
  std::string reason;         // e.g. "file ends inside a chunk record (truncated)", "chunk CRC mismatch"
  std::uint64_t messages_read = 0;
  std::string message() const;  // one line for a person
};

class RecordingReader {
 public:
  /// Opens `path`. Throws std::runtime_error naming the path when it is missing or not an MCAP file
  /// at all (its first bytes are not the MCAP magic). A file cut inside the magic or the header is
  /// a truncated recording, not an error: next() returns false at once and damage() says so.
  explicit RecordingReader(const std::string& path);
  ~RecordingReader();
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;

  /// The next message in file order. False at the end of the data, or at damage (see damage()).
  /// Never throws. Each chunk's CRC is checked before any of its messages is returned; record
  /// lengths are checked against the file size before anything is allocated for them.
  bool next(RecordedMessage& out);
  /// Set once next() has stopped at damage; empty for an intact file. Damage after the last
  /// message (summary or footer missing or cut: every message was read, but index-based readers
  /// such as rosbags cannot open the file) is reported too, once next() has returned false.
  const std::optional<RecordingDamage>& damage() const;
  /// The header's profile ("ros2" for ours).
  const std::string& profile() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Decodes a message of the matching schema; false when the schema differs or the CDR is bad.
bool decode(const RecordedMessage& m, rsrio_msgs::msg::RadarFrame& out);
bool decode(const RecordedMessage& m, sensor_msgs::msg::Imu& out);
bool decode(const RecordedMessage& m, nav_msgs::msg::Odometry& out);
bool decode(const RecordedMessage& m, sensor_msgs::msg::PointCloud2& out);
bool decode(const RecordedMessage& m, geometry_msgs::msg::PoseStamped& out);

/// The radar configuration model <-> its message form (carried in every RadarFrame).
rsrio_msgs::msg::RadarConfig to_msg(const RadarConfig& config);
/// Throws ConfigError (file "<recording>") when the message holds an invalid configuration.
RadarConfig from_msg(const rsrio_msgs::msg::RadarConfig& msg);

}  // namespace rsrio
