// The recorded message types: their ROS 2 schema names and fastddsgen PubSubTypes, and CDR
// serialisation through those PubSubTypes into (or out of) memory we own.
#pragma once

#include <cstdint>
#include <limits>
#include <string_view>

#include <fastdds/dds/core/policy/QosPolicies.hpp>
#include <fastdds/rtps/common/SerializedPayload.hpp>

#include "geometry_msgs/msg/PoseStampedPubSubTypes.hpp"
#include "nav_msgs/msg/OdometryPubSubTypes.hpp"
#include "rsrio_msgs/msg/RadarFramePubSubTypes.hpp"
#include "sensor_msgs/msg/ImuPubSubTypes.hpp"
#include "sensor_msgs/msg/PointCloud2PubSubTypes.hpp"

namespace rsrio::recording_detail {

template <typename Message>
struct MessageType;

template <>
struct MessageType<rsrio_msgs::msg::RadarFrame> {
  using PubSubType = rsrio_msgs::msg::RadarFramePubSubType;
  static constexpr std::string_view kSchemaName = "rsrio_msgs/msg/RadarFrame";
};
template <>
struct MessageType<sensor_msgs::msg::Imu> {
  using PubSubType = sensor_msgs::msg::ImuPubSubType;
  static constexpr std::string_view kSchemaName = "sensor_msgs/msg/Imu";
};
template <>
struct MessageType<nav_msgs::msg::Odometry> {
  using PubSubType = nav_msgs::msg::OdometryPubSubType;
  static constexpr std::string_view kSchemaName = "nav_msgs/msg/Odometry";
};
template <>
struct MessageType<sensor_msgs::msg::PointCloud2> {
  using PubSubType = sensor_msgs::msg::PointCloud2PubSubType;
  static constexpr std::string_view kSchemaName = "sensor_msgs/msg/PointCloud2";
};
template <>
struct MessageType<geometry_msgs::msg::PoseStamped> {
  using PubSubType = geometry_msgs::msg::PoseStampedPubSubType;
  static constexpr std::string_view kSchemaName = "geometry_msgs/msg/PoseStamped";
};

/// ROS 2 stores plain little-endian CDR (XCDR1), as rmw_fastrtps publishes it: encapsulation
/// header 00 01 00 00.
inline constexpr auto kCdrRepresentation =
    eprosima::fastdds::dds::DataRepresentationId_t::XCDR_DATA_REPRESENTATION;

/// A SerializedPayload_t over memory it does not own, so that the PubSubType serialises straight
/// into the open chunk (or deserialises straight from a record) without an extra copy. The
/// payload frees `data` in its destructor unless it is detached first, which ~BorrowedPayload does.
class BorrowedPayload {
 public:
  BorrowedPayload(std::uint8_t* data, std::uint32_t size) {
    payload_.data = data;
    payload_.max_size = size;
    payload_.length = size;
  }
  ~BorrowedPayload() {
    payload_.data = nullptr;
    payload_.max_size = 0;
    payload_.length = 0;
  }
  BorrowedPayload(const BorrowedPayload&) = delete;
  BorrowedPayload& operator=(const BorrowedPayload&) = delete;

  eprosima::fastdds::rtps::SerializedPayload_t& get() { return payload_; }

 private:
  eprosima::fastdds::rtps::SerializedPayload_t payload_;
};

}  // namespace rsrio::recording_detail
