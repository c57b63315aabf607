#include "rsrio/runtime/odometry_publisher.hpp"

#include <algorithm>

#include "geometry_msgs/msg/PoseStampedPubSubTypes.hpp"
#include "nav_msgs/msg/OdometryPubSubTypes.hpp"
#include "rsrio_msgs/msg/StatusPubSubTypes.hpp"

namespace fdds = eprosima::fastdds::dds;

namespace rsrio {
namespace {

void stamp(std::int64_t ns, builtin_interfaces::msg::Time& t) {
  // builtin_interfaces/Time: sec may be negative, nanosec always in [0, 1e9).
  std::int64_t sec = ns / 1000000000, rem = ns % 1000000000;
  if (rem < 0) {
    rem += 1000000000;
    --sec;
  }
  t.sec(static_cast<std::int32_t>(sec));
  t.nanosec(static_cast<std::uint32_t>(rem));
}

void fill_pose(const std::array<double, 3>& position, const std::array<double, 4>& orientation,
               geometry_msgs::msg::Pose& pose) {
  pose.position().x(position[0]);
  pose.position().y(position[1]);
  pose.position().z(position[2]);
  pose.orientation().x(orientation[0]);
  pose.orientation().y(orientation[1]);
  pose.orientation().z(orientation[2]);
  pose.orientation().w(orientation[3]);
}

}  // namespace

void to_msg(const PoseOutput& p, const PublisherOptions& o, nav_msgs::msg::Odometry& odom) {
  stamp(p.stamp_ns, odom.header().stamp());
  odom.header().frame_id(o.odom_frame_id);
  odom.child_frame_id(o.base_frame_id);
  fill_pose(p.position, p.orientation, odom.pose().pose());
  odom.pose().covariance(p.pose_covariance);
  odom.twist().twist().linear().x(p.linear_velocity[0]);
  odom.twist().twist().linear().y(p.linear_velocity[1]);
  odom.twist().twist().linear().z(p.linear_velocity[2]);
  odom.twist().twist().angular().x(p.angular_velocity[0]);
  odom.twist().twist().angular().y(p.angular_velocity[1]);
  odom.twist().twist().angular().z(p.angular_velocity[2]);
  odom.twist().covariance(p.twist_covariance);
}

void to_msg(const PoseOutput& p, const PublisherOptions& o, geometry_msgs::msg::PoseStamped& pose) {
  stamp(p.stamp_ns, pose.header().stamp());
  if (p.has_map_pose) {
    // The backend's estimate: the refined keyframe pose composed with the frontend's motion since.
    pose.header().frame_id(o.map_frame_id);
    fill_pose(p.map_position, p.map_orientation, pose.pose());
  } else {
    pose.header().frame_id(o.odom_frame_id);
    fill_pose(p.position, p.orientation, pose.pose());
  }
}

OdometryPublisher::OdometryPublisher(DdsParticipant& participant, const PublisherOptions& options)
    : options_(options) {
  odom_ = participant.make_writer(ros_topic_to_dds(options.odom_topic),
                                  fdds::TypeSupport(new nav_msgs::msg::OdometryPubSubType()), QosPreset::kOdometry);
  pose_ = participant.make_writer(ros_topic_to_dds(options.pose_topic),
                                  fdds::TypeSupport(new geometry_msgs::msg::PoseStampedPubSubType()),
                                  QosPreset::kOdometry);
  status_ = participant.make_writer(ros_topic_to_dds(options.status_topic),
                                    fdds::TypeSupport(new rsrio_msgs::msg::StatusPubSubType()), QosPreset::kLatched);
}

bool OdometryPublisher::publish(const PoseOutput& p) {
  nav_msgs::msg::Odometry odom;
  geometry_msgs::msg::PoseStamped pose;
  to_msg(p, options_, odom);
  to_msg(p, options_, pose);
  bool ok = odom_->write(&odom) == fdds::RETCODE_OK;
  ok = (pose_->write(&pose) == fdds::RETCODE_OK) && ok;
  if (!ok) ++write_failures_;
  return ok;
}

bool OdometryPublisher::publish(const rsrio_msgs::msg::Status& status) {
  const bool ok = status_->write(&status) == fdds::RETCODE_OK;
  if (!ok) ++write_failures_;
  return ok;
}

int OdometryPublisher::pose_subscribers() {
  fdds::PublicationMatchedStatus odom, pose;
  if (odom_ == nullptr || pose_ == nullptr || odom_->get_publication_matched_status(odom) != fdds::RETCODE_OK ||
      pose_->get_publication_matched_status(pose) != fdds::RETCODE_OK)
    return 0;
  return std::min(odom.current_count, pose.current_count);
}

}  // namespace rsrio
