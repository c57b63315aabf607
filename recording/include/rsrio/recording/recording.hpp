// Recordings: rosbag2-compatible MCAP files (profile "ros2", CDR messages serialised with Fast
// CDR through the fastddsgen types, "ros2msg" schemas embedded, chunked with CRCs, summary and
// index), written and read by our own implementation of the MCAP format.
//
// A reader goes through the data section record by record, so a file cut at any byte (a crash, a
// full disk) is read up to the damage, and damage() tells where and why it stopped.
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
};

class RecordingWriter {
 public:
  /// Creates (truncates) `path`. Throws std::runtime_error naming the path on failure.
  explicit RecordingWriter(const std::string& path, RecordingWriterOptions options = {});
  ~RecordingWriter();  // close()s; never throws
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  // One channel per topic, made on its first message. log_time_ns: when the message was
  // received/made (ns since the epoch); publish time = the message's header stamp.
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
  /// Opens `path`. Throws std::runtime_error when it is missing or not an MCAP file at all.
  explicit RecordingReader(const std::string& path);
  ~RecordingReader();
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;

  /// The next message in file order. False at the end of the data, or at damage (see damage()).
  bool next(RecordedMessage& out);
  /// Set once next() has stopped at damage; empty for an intact file.
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
