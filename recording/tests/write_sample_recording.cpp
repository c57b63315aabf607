// write_sample_recording BAG_DIR EXPECTED_JSON
//
// Writes a small recording of every recorded type as a rosbag2 bag (BAG_DIR/metadata.yaml and
// BAG_DIR/<name>_0.mcap) and, to EXPECTED_JSON, the topics, counts and the field values of some of
// the messages, so that tests/check_with_rosbags.py can compare what python3-rosbags decodes with
// what was written.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/recording/recording.hpp"
#include "recording_test_support.hpp"

namespace {

using namespace rsrio;
using test::kT0;
using test::stamp;

// ---- a minimal JSON writer: exact doubles (%.17g round-trips through Python's float) ----------
std::string number(double v) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}
std::string number(std::uint64_t v) { return std::to_string(v); }
std::string number(std::int64_t v) { return std::to_string(v); }
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}
template <typename Container>
std::string list(const Container& values) {
  std::string out = "[";
  for (const auto& v : values) {
    if (out.size() > 1) out += ", ";
    if constexpr (std::is_floating_point_v<std::decay_t<decltype(v)>>) {
      out += number(static_cast<double>(v));
    } else if constexpr (std::is_signed_v<std::decay_t<decltype(v)>>) {
      out += number(static_cast<std::int64_t>(v));
    } else {
      out += number(static_cast<std::uint64_t>(v));
    }
  }
  return out + "]";
}
std::string object(const std::vector<std::pair<std::string, std::string>>& members) {
  std::string out = "{";
  for (const auto& [key, value] : members) {
    if (out.size() > 1) out += ", ";
    out += quoted(key) + ": " + value;
  }
  return out + "}";
}

std::string json(const std_msgs::msg::Header& h) {
  return object({{"stamp", object({{"sec", number(std::int64_t{h.stamp().sec()})},
                                   {"nanosec", number(std::uint64_t{h.stamp().nanosec()})}})},
                 {"frame_id", quoted(h.frame_id())}});
}
std::string json(const geometry_msgs::msg::Vector3& v) {
  return object({{"x", number(v.x())}, {"y", number(v.y())}, {"z", number(v.z())}});
}
std::string json(const geometry_msgs::msg::Point& v) {
  return object({{"x", number(v.x())}, {"y", number(v.y())}, {"z", number(v.z())}});
}
std::string json(const geometry_msgs::msg::Quaternion& q) {
  return object({{"x", number(q.x())}, {"y", number(q.y())}, {"z", number(q.z())}, {"w", number(q.w())}});
}
std::string json(const geometry_msgs::msg::Pose& p) {
  return object({{"position", json(p.position())}, {"orientation", json(p.orientation())}});
}
std::string json(const sensor_msgs::msg::Imu& m) {
  return object({{"header", json(m.header())},
                 {"orientation", json(m.orientation())},
                 {"orientation_covariance", list(m.orientation_covariance())},
                 {"angular_velocity", json(m.angular_velocity())},
                 {"angular_velocity_covariance", list(m.angular_velocity_covariance())},
                 {"linear_acceleration", json(m.linear_acceleration())},
                 {"linear_acceleration_covariance", list(m.linear_acceleration_covariance())}});
}
std::string json(const nav_msgs::msg::Odometry& m) {
  return object(
      {{"header", json(m.header())},
       {"child_frame_id", quoted(m.child_frame_id())},
       {"pose", object({{"pose", json(m.pose().pose())}, {"covariance", list(m.pose().covariance())}})},
       {"twist", object({{"twist", object({{"linear", json(m.twist().twist().linear())},
                                           {"angular", json(m.twist().twist().angular())}})},
                         {"covariance", list(m.twist().covariance())}})}});
}
std::string json(const geometry_msgs::msg::PoseStamped& m) {
  return object({{"header", json(m.header())}, {"pose", json(m.pose())}});
}
std::string json(const sensor_msgs::msg::PointCloud2& m) {
  std::string field_list = "[";
  for (const auto& f : m.fields()) {
    if (field_list.size() > 1) field_list += ", ";
    field_list += object({{"name", quoted(f.name())},
                          {"offset", number(std::uint64_t{f.offset()})},
                          {"datatype", number(std::uint64_t{f.datatype()})},
                          {"count", number(std::uint64_t{f.count()})}});
  }
  field_list += "]";
  return object({{"header", json(m.header())},
                 {"height", number(std::uint64_t{m.height()})},
                 {"width", number(std::uint64_t{m.width()})},
                 {"fields", field_list},
                 {"is_bigendian", m.is_bigendian() ? "true" : "false"},
                 {"point_step", number(std::uint64_t{m.point_step()})},
                 {"row_step", number(std::uint64_t{m.row_step()})},
                 {"data", list(m.data())},
                 {"is_dense", m.is_dense() ? "true" : "false"}});
}
std::string json(const rsrio_msgs::msg::RadarConfig& c) {
  return object({{"preset", quoted(c.preset())},
                 {"start_frequency_ghz", number(c.start_frequency_ghz())},
                 {"slope_mhz_per_us", number(c.slope_mhz_per_us())},
                 {"adc_sample_rate_ksps", number(c.adc_sample_rate_ksps())},
                 {"samples_per_chirp", number(std::uint64_t{c.samples_per_chirp()})},
                 {"idle_time_us", number(c.idle_time_us())},
                 {"adc_start_time_us", number(c.adc_start_time_us())},
                 {"ramp_end_time_us", number(c.ramp_end_time_us())},
                 {"loops", number(std::uint64_t{c.loops()})},
                 {"tx_order", list(c.tx_order())},
                 {"frame_period_ms", number(c.frame_period_ms())},
                 {"angle_fft_size", number(std::uint64_t{c.angle_fft_size()})},
                 {"design_frequency_ghz", number(c.design_frequency_ghz())},
                 {"tx_azimuth", list(c.tx_azimuth())},
                 {"tx_elevation", list(c.tx_elevation())},
                 {"rx_azimuth", list(c.rx_azimuth())},
                 {"rx_elevation", list(c.rx_elevation())},
                 {"capture_format", quoted(c.capture_format())},
                 {"iq_order", quoted(c.iq_order())},
                 {"sample_layout", quoted(c.sample_layout())},
                 {"offset_binary", c.offset_binary() ? "true" : "false"},
                 {"lvds_lanes", number(std::uint64_t{c.lvds_lanes()})},
                 {"calibration_gain_re", list(c.calibration_gain_re())},
                 {"calibration_gain_im", list(c.calibration_gain_im())},
                 {"calibration_frequency_offset_hz", list(c.calibration_frequency_offset_hz())}});
}
std::string json(const rsrio_msgs::msg::RadarFrame& m) {
  // The ADC bytes in full would be megabytes of JSON: their length, head and sum stand in for them.
  std::uint64_t sum = 0;
  for (std::uint8_t b : m.adc()) sum += b;
  const std::vector<std::uint8_t> head(m.adc().begin(), m.adc().begin() + 32);
  return object({{"header", json(m.header())},
                 {"frame_number", number(m.frame_number())},
                 {"monotonic_ns", number(m.monotonic_ns())},
                 {"flags", number(std::uint64_t{m.flags()})},
                 {"lost_bytes", number(std::uint64_t{m.lost_bytes()})},
                 {"config", json(m.config())},
                 {"adc", object({{"length", number(std::uint64_t{m.adc().size()})},
                                 {"head", list(head)},
                                 {"sum", number(sum)}})}});
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: write_sample_recording BAG_DIR EXPECTED_JSON\n";
    return 2;
  }
  try {
    const std::filesystem::path bag_dir = argv[1];
    std::filesystem::create_directories(bag_dir);
    const std::filesystem::path mcap = bag_dir / (bag_dir.filename().string() + "_0.mcap");

    RecordingWriterOptions options;
    options.chunk_bytes = 1024 * 1024;  // raw frames of 768 KiB: several chunks
    options.write_rosbag2_metadata = true;
    RecordingWriter writer(mcap.string(), options);

    std::map<std::string, std::pair<std::string, int>> topics;  // topic -> (type, count)
    std::vector<std::string> checked;                          // {"topic", index, log_time, fields}
    auto note = [&](const std::string& topic, const std::string& type, std::uint64_t log_time, const std::string& fields,
                    bool check) {
      auto& [t, count] = topics[topic];
      t = type;
      if (check)
        checked.push_back(object({{"topic", quoted(topic)},
                                  {"index", number(std::uint64_t(count))},
                                  {"log_time", number(log_time)},
                                  {"fields", fields}}));
      ++count;
    };

    RadarConfig config = radar_preset("xwr1843");
    config.calibration.gain.assign(12, {0.875, -0.125});
    const std::size_t frame_bytes = derive(config).frame_bytes;
    std::mt19937 random(1234);

    for (int i = 0; i < 40; ++i) {
      const std::uint64_t t = kT0 + 2'500'000ull * static_cast<std::uint64_t>(i);
      sensor_msgs::msg::Imu imu;
      stamp(imu.header(), t - 1000, "imu_link");
      imu.orientation().x(0.01 * i);
      imu.orientation().y(-0.5);
      imu.orientation().z(0.25);
      imu.orientation().w(0.8);
      for (int k = 0; k < 9; ++k) {
        imu.orientation_covariance()[k] = k == 0 || k == 4 || k == 8 ? 1e-3 : 0.0;
        imu.angular_velocity_covariance()[k] = 1e-5 * (k + 1);
        imu.linear_acceleration_covariance()[k] = -1e-4 * (k + i);
      }
      imu.angular_velocity().x(0.001 * i);
      imu.angular_velocity().y(-0.02);
      imu.angular_velocity().z(1.0 / 3.0);
      imu.linear_acceleration().x(0.1 * i);
      imu.linear_acceleration().y(-0.3);
      imu.linear_acceleration().z(9.80665);
      writer.write(topics::kImu, imu, t);
      note(topics::kImu, "sensor_msgs/msg/Imu", t, json(imu), i == 0 || i == 17);

      if (i % 10 == 0) {
        const int n = i / 10;
        rsrio_msgs::msg::RadarFrame frame;
        stamp(frame.header(), t - 2000, "radar");
        frame.frame_number(static_cast<std::uint64_t>(500 + n));
        frame.monotonic_ns(987'654'321'000ull + 100'000'000ull * static_cast<std::uint64_t>(n));
        frame.flags(rsrio_msgs::msg::RadarFrame_Constants::FLAG_SIMULATED |
                    (n == 3 ? rsrio_msgs::msg::RadarFrame_Constants::FLAG_DAMAGED : 0u));
        frame.lost_bytes(n == 3 ? 2912u : 0u);
        frame.config(to_msg(config));
        std::vector<std::uint8_t> adc(frame_bytes);
        for (auto& b : adc) b = static_cast<std::uint8_t>(random());
        frame.adc(std::move(adc));
        writer.write(topics::kRadarRaw, frame, t + 1);
        note(topics::kRadarRaw, "rsrio_msgs/msg/RadarFrame", t + 1, json(frame), n == 0 || n == 3);

        sensor_msgs::msg::PointCloud2 cloud;
        stamp(cloud.header(), t - 2000, "radar");
        cloud.fields(test::point_cloud_fields());
        cloud.height(1);
        cloud.width(static_cast<std::uint32_t>(3 + n));
        cloud.point_step(20);
        cloud.row_step(20 * cloud.width());
        std::vector<std::uint8_t> data(cloud.row_step());
        for (std::size_t k = 0; k < data.size(); ++k) data[k] = static_cast<std::uint8_t>(3 * k + static_cast<std::size_t>(n));
        cloud.data(data);
        cloud.is_dense(true);
        writer.write(topics::kRadarPoints, cloud, t + 2);
        note(topics::kRadarPoints, "sensor_msgs/msg/PointCloud2", t + 2, json(cloud), n == 1);

        nav_msgs::msg::Odometry truth;
        stamp(truth.header(), t - 2000, "world");
        truth.child_frame_id("base_link");
        truth.pose().pose().position().x(0.5 * n);
        truth.pose().pose().position().y(-1.25);
        truth.pose().pose().position().z(0.0);
        truth.pose().pose().orientation().z(0.6);
        truth.pose().pose().orientation().w(0.8);
        truth.twist().twist().linear().x(1.0 + n);
        truth.twist().twist().angular().z(-0.125 * n);
        for (int k = 0; k < 36; ++k) {
          truth.pose().covariance()[k] = k % 7 == 0 ? 1e-6 * (k + 1) : 0.0;
          truth.twist().covariance()[k] = k % 7 == 0 ? 2e-6 * (k + 1) : 1e-12 * k;
        }
        writer.write(topics::kGroundTruth, truth, t + 3);
        note(topics::kGroundTruth, "nav_msgs/msg/Odometry", t + 3, json(truth), n == 2);
      }

      if (i % 20 == 5) {
        nav_msgs::msg::Odometry odom;
        stamp(odom.header(), t, "odom");
        odom.child_frame_id("radar_base");
        odom.pose().pose().position().x(3.0 * i);
        odom.pose().pose().orientation().w(1.0);
        odom.twist().twist().linear().y(0.75);
        for (int k = 0; k < 36; ++k) odom.pose().covariance()[k] = 0.001 * k;
        writer.write(topics::kOdometry, odom, t + 4);
        note(topics::kOdometry, "nav_msgs/msg/Odometry", t + 4, json(odom), i == 25);

        geometry_msgs::msg::PoseStamped pose;
        stamp(pose.header(), t, "map");
        pose.pose().position().x(-7.5);
        pose.pose().position().y(0.03125 * i);
        pose.pose().orientation().x(0.5);
        pose.pose().orientation().y(0.5);
        pose.pose().orientation().z(0.5);
        pose.pose().orientation().w(0.5);
        writer.write("/rsrio/pose", pose, t + 5);
        note("/rsrio/pose", "geometry_msgs/msg/PoseStamped", t + 5, json(pose), i == 5);
      }
    }
    writer.close();

    std::string topic_list;
    for (const auto& [topic, info] : topics) {
      if (!topic_list.empty()) topic_list += ", ";
      topic_list += quoted(topic) + ": " +
                    object({{"type", quoted(info.first)}, {"count", number(std::uint64_t(info.second))}});
    }
    std::string message_list = "[";
    for (const std::string& m : checked) message_list += (message_list.size() > 1 ? ",\n  " : "\n  ") + m;
    message_list += "\n]";
    std::ofstream out(argv[2]);
    out << object({{"mcap", quoted(mcap.filename().string())},
                   {"topics", "{" + topic_list + "}"},
                   {"messages", message_list}})
        << "\n";
    out.close();
    if (!out) throw std::runtime_error(std::string("cannot write ") + argv[2]);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "write_sample_recording: " << e.what() << "\n";
    return 1;
  }
}
