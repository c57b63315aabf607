// Shared by the recording tests: sample messages, a scratch directory, and an MCAP walker written
// independently of the reader (it trusts nothing but the spec) to find where records are.
#pragma once

#include <cstdint>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/recording/recording.hpp"
#include "scratch_dir.hpp"

namespace rsrio::test {

using rsrio::testing::ScratchDir;

inline constexpr std::uint64_t kT0 = 1'700'000'000'000'000'000ull;  // 2023-11-14, ns since the epoch

inline void stamp(std_msgs::msg::Header& header, std::uint64_t t_ns, const std::string& frame) {
  header.stamp().sec(static_cast<std::int32_t>(t_ns / 1'000'000'000));
  header.stamp().nanosec(static_cast<std::uint32_t>(t_ns % 1'000'000'000));
  header.frame_id(frame);
}

inline sensor_msgs::msg::Imu make_imu(int i) {
  sensor_msgs::msg::Imu m;
  stamp(m.header(), kT0 + 2'500'000ull * static_cast<std::uint64_t>(i), "imu_link");
  m.orientation().x(0.01 * i);
  m.orientation().y(-0.02 * i);
  m.orientation().z(0.5);
  m.orientation().w(0.75);
  for (int k = 0; k < 9; ++k) {
    m.orientation_covariance()[k] = 1e-4 * (k + 1);
    m.angular_velocity_covariance()[k] = 2e-4 * (k + 1) + i;
    m.linear_acceleration_covariance()[k] = -3e-4 * (k + 1);
  }
  m.angular_velocity().x(0.001 * i);
  m.angular_velocity().y(-0.25);
  m.angular_velocity().z(1.0 / 3.0);
  m.linear_acceleration().x(0.1 * i);
  m.linear_acceleration().y(0.2);
  m.linear_acceleration().z(9.80665);
  return m;
}

inline nav_msgs::msg::Odometry make_odometry(int i) {
  nav_msgs::msg::Odometry m;
  stamp(m.header(), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i), "odom");
  m.child_frame_id("base_link");
  m.pose().pose().position().x(1.5 * i);
  m.pose().pose().position().y(-2.25);
  m.pose().pose().position().z(0.125 * i);
  m.pose().pose().orientation().x(0.0);
  m.pose().pose().orientation().y(0.0);
  m.pose().pose().orientation().z(0.6);
  m.pose().pose().orientation().w(0.8);
  m.twist().twist().linear().x(3.0 + i);
  m.twist().twist().linear().y(-0.5);
  m.twist().twist().linear().z(0.0);
  m.twist().twist().angular().x(0.0);
  m.twist().twist().angular().y(0.0);
  m.twist().twist().angular().z(0.05 * i);
  for (int k = 0; k < 36; ++k) {
    m.pose().covariance()[k] = k % 7 == 0 ? 0.01 * (k + 1) : 0.0;
    m.twist().covariance()[k] = k % 7 == 0 ? 0.02 * (k + 1) + i : 1e-9 * k;
  }
  return m;
}

/// The fields of a CFAR point cloud: x, y, z, v_doppler_mps, snr_db, float32 each (20 bytes a point).
inline std::vector<sensor_msgs::msg::PointField> point_cloud_fields() {
  const char* names[] = {"x", "y", "z", "v_doppler_mps", "snr_db"};
  std::vector<sensor_msgs::msg::PointField> fields;
  for (std::uint32_t f = 0; f < 5; ++f) {
    sensor_msgs::msg::PointField field;
    field.name(names[f]);
    field.offset(4 * f);
    field.datatype(sensor_msgs::msg::PointField_Constants::FLOAT32);
    field.count(1);
    fields.push_back(field);
  }
  return fields;
}

inline sensor_msgs::msg::PointCloud2 make_point_cloud(int i, int points) {
  sensor_msgs::msg::PointCloud2 m;
  stamp(m.header(), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i), "radar");
  m.fields(point_cloud_fields());
  m.height(1);
  m.width(static_cast<std::uint32_t>(points));
  m.is_bigendian(false);
  m.point_step(20);
  m.row_step(20 * static_cast<std::uint32_t>(points));
  std::vector<std::uint8_t> data(20 * static_cast<std::size_t>(points));
  for (std::size_t k = 0; k < data.size(); ++k) data[k] = static_cast<std::uint8_t>(k * 7 + static_cast<std::size_t>(i));
  m.data(data);
  m.is_dense(true);
  return m;
}

inline geometry_msgs::msg::PoseStamped make_pose(int i) {
  geometry_msgs::msg::PoseStamped m;
  stamp(m.header(), kT0 + 50'000'000ull * static_cast<std::uint64_t>(i), "map");
  m.pose().position().x(10.0 + i);
  m.pose().position().y(20.0);
  m.pose().position().z(-0.5 * i);
  m.pose().orientation().w(1.0);
  return m;
}

inline rsrio_msgs::msg::RadarFrame make_radar_frame(int i, std::size_t adc_bytes) {
  rsrio_msgs::msg::RadarFrame m;
  stamp(m.header(), kT0 + 100'000'000ull * static_cast<std::uint64_t>(i), "radar");
  m.frame_number(static_cast<std::uint64_t>(1000 + i));
  m.monotonic_ns(123'456'789'000ull + 100'000'000ull * static_cast<std::uint64_t>(i));
  m.flags(i % 2 == 0 ? rsrio_msgs::msg::RadarFrame_Constants::FLAG_SIMULATED
                     : rsrio_msgs::msg::RadarFrame_Constants::FLAG_SIMULATED |
                           rsrio_msgs::msg::RadarFrame_Constants::FLAG_DAMAGED);
  m.lost_bytes(static_cast<std::uint32_t>(i % 2) * 1456u);
  RadarConfig config = radar_preset("xwr1843");
  config.calibration.gain.assign(12, {0.5, -0.25});
  m.config(to_msg(config));
  std::vector<std::uint8_t> adc(adc_bytes);
  std::mt19937 random(static_cast<std::uint32_t>(i));
  for (auto& byte : adc) byte = static_cast<std::uint8_t>(random());
  m.adc(std::move(adc));
  return m;
}

struct ReadResult {
  std::vector<RecordedMessage> messages;
  std::optional<RecordingDamage> damage;
  std::string profile;
};

inline ReadResult read_all(const std::string& path) {
  RecordingReader reader(path);
  ReadResult result;
  RecordedMessage message;
  while (reader.next(message)) result.messages.push_back(message);
  result.damage = reader.damage();
  result.profile = reader.profile();
  return result;
}

inline std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void write_bytes(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

inline std::uint64_t le(const std::vector<std::uint8_t>& bytes, std::size_t at, int width) {
  std::uint64_t v = 0;
  for (int i = 0; i < width; ++i) v |= static_cast<std::uint64_t>(bytes.at(at + static_cast<std::size_t>(i))) << (8 * i);
  return v;
}

/// A top-level record as the spec lays it out.
struct RecordSpan {
  std::uint8_t opcode = 0;
  std::size_t offset = 0;  // of the opcode
  std::size_t end = 0;     // one past the record
  std::size_t chunk_messages = 0;      // chunks: message records inside
  std::size_t chunk_records_offset = 0;  // chunks: where the records start
};

/// The records of a complete file from the header to the footer (the test's own walk).
inline std::vector<RecordSpan> walk_records(const std::vector<std::uint8_t>& bytes) {
  std::vector<RecordSpan> records;
  std::size_t at = 8;
  while (at + 9 <= bytes.size()) {
    RecordSpan r;
    r.opcode = bytes[at];
    r.offset = at;
    r.end = at + 9 + static_cast<std::size_t>(le(bytes, at + 1, 8));
    if (r.opcode == 0x06) {
      const std::size_t compression_length = static_cast<std::size_t>(le(bytes, at + 9 + 28, 4));
      const std::size_t records_length_at = at + 9 + 32 + compression_length;
      r.chunk_records_offset = records_length_at + 8;
      const std::size_t records_end = r.chunk_records_offset + static_cast<std::size_t>(le(bytes, records_length_at, 8));
      for (std::size_t inner = r.chunk_records_offset; inner < records_end;
           inner += 9 + static_cast<std::size_t>(le(bytes, inner + 1, 8)))
        if (bytes[inner] == 0x05) ++r.chunk_messages;
    }
    records.push_back(r);
    if (r.opcode == 0x02) break;
    at = r.end;
  }
  return records;
}

}  // namespace rsrio::test
