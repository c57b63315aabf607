// What the RIO thread hands to the publisher thread, and the publisher's DDS side: one pose per
// radar frame as nav_msgs/Odometry and geometry_msgs/PoseStamped, and the daemon's status.
//
// PoseOutput is plain data so the SPSC queue moves it without allocating; the DDS messages (which
// hold std::string and std::vector) are built on the publisher thread only.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include <fastdds/dds/publisher/DataWriter.hpp>

#include "rsrio/runtime/dds.hpp"
#include "rsrio_msgs/msg/Status.hpp"

namespace nav_msgs::msg {
class Odometry;
}
namespace geometry_msgs::msg {
class PoseStamped;
}

namespace rsrio {

struct PoseOutput {
  std::int64_t stamp_ns = 0;            // the radar frame's stamp (header.stamp), ns since the epoch
  std::int64_t frame_complete_mono_ns = 0;  // CLOCK_MONOTONIC when the frame was complete (latency)
  std::int64_t rio_pickup_mono_ns = 0;  // when the RIO thread took the frame from its queue
  std::int64_t rio_start_mono_ns = 0, rio_end_mono_ns = 0;  // its processing (after the IMU wait)
  std::uint64_t frame_number = 0;
  std::array<double, 3> position{};     // odom frame, m
  std::array<double, 4> orientation{0, 0, 0, 1};  // odom <- base, quaternion x y z w
  std::array<double, 3> linear_velocity{};   // base frame, m/s (ROS: twist in child_frame_id)
  std::array<double, 3> angular_velocity{};  // base frame, rad/s
  std::array<double, 36> pose_covariance{};   // ROS order: x y z, rot x y z; row-major
  std::array<double, 36> twist_covariance{};
  bool radar_used = false;              // this frame's ego-velocity entered the estimate
  // With the backend: the pose above corrected (splat::OdomCorrection: map_T_odom *, at its
  // keyframe's height on a level floor; PoseStamped in map_frame_id).
  bool has_map_pose = false;
  std::array<double, 3> map_position{};
  std::array<double, 4> map_orientation{0, 0, 0, 1};
};

struct PublisherOptions {
  std::string odom_topic = "/rsrio/odom";   // ROS 2 names
  std::string pose_topic = "/rsrio/pose";
  std::string status_topic = "/rsrio/status";
  std::string odom_frame_id = "odom";
  std::string base_frame_id = "base_link";
  std::string map_frame_id = "map";
};

/// The messages as they go out (also used by tests and rsrio-echo to compare).
void to_msg(const PoseOutput& p, const PublisherOptions& o, nav_msgs::msg::Odometry& odom);
void to_msg(const PoseOutput& p, const PublisherOptions& o, geometry_msgs::msg::PoseStamped& pose);

class OdometryPublisher {
 public:
  /// Makes the three writers (odometry and pose: kOdometry QoS; status: kLatched).
  OdometryPublisher(DdsParticipant& participant, const PublisherOptions& options);
  /// DDS writes; false when Fast DDS refused one (counted).
  bool publish(const PoseOutput& pose);
  bool publish(const rsrio_msgs::msg::Status& status);
  std::uint64_t write_failures() const { return write_failures_; }
  /// Readers matched by both the odometry and the pose writer (the fewer of the two). A reader can
  /// see its match before the writer does; a volatile sample written in between is lost to it.
  int pose_subscribers();

 private:
  PublisherOptions options_;
  eprosima::fastdds::dds::DataWriter* odom_ = nullptr;
  eprosima::fastdds::dds::DataWriter* pose_ = nullptr;
  eprosima::fastdds::dds::DataWriter* status_ = nullptr;
  std::uint64_t write_failures_ = 0;
};

}  // namespace rsrio
