// decode(): CDR bytes of a recorded message -> the fastddsgen type, through its PubSubType.
#include <cstdint>
#include <limits>
#include <utility>

#include "message_types.hpp"
#include "rsrio/recording/recording.hpp"

namespace rsrio {

namespace {

using recording_detail::BorrowedPayload;
using recording_detail::MessageType;

template <typename Message>
bool decode_as(const RecordedMessage& recorded, Message& out) {
  using Type = MessageType<Message>;
  if (recorded.schema_name != Type::kSchemaName) return false;
  const std::vector<std::uint8_t>& cdr = recorded.cdr;
  // Only plain CDR (what ROS 2 stores): encapsulation 00 00 (big-endian) or 00 01 (little-endian).
  // Any other header would switch Fast CDR to XCDR2, whose sequence decoding sizes a vector from
  // the length in the data before checking it against the bytes present: a corrupt record could
  // then allocate gigabytes.
  if (cdr.size() < 4 || cdr[0] != 0x00 || cdr[1] > 0x01) return false;
  if (cdr.size() > std::numeric_limits<std::uint32_t>::max()) return false;
  try {
    typename Type::PubSubType pubsub;
    // deserialize() takes a mutable payload but only reads the bytes.
    BorrowedPayload payload(const_cast<std::uint8_t*>(cdr.data()), static_cast<std::uint32_t>(cdr.size()));
    Message decoded;
    if (!pubsub.deserialize(payload.get(), &decoded)) return false;
    out = std::move(decoded);  // `out` is untouched when decoding fails
    return true;
  } catch (...) {  // Fast CDR exceptions the PubSubType lets through, std::bad_alloc, std::length_error
    return false;
  }
}

}  // namespace

bool decode(const RecordedMessage& m, rsrio_msgs::msg::RadarFrame& out) { return decode_as(m, out); }
bool decode(const RecordedMessage& m, sensor_msgs::msg::Imu& out) { return decode_as(m, out); }
bool decode(const RecordedMessage& m, nav_msgs::msg::Odometry& out) { return decode_as(m, out); }
bool decode(const RecordedMessage& m, sensor_msgs::msg::PointCloud2& out) { return decode_as(m, out); }
bool decode(const RecordedMessage& m, geometry_msgs::msg::PoseStamped& out) { return decode_as(m, out); }

}  // namespace rsrio
