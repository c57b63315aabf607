// The publisher's message mapping (REP-105 frames, stamps, covariance order) and a real DDS round
// trip of what the daemon publishes, read by another participant as a ROS 2 node would.
#include "rsrio/runtime/odometry_publisher.hpp"

#include <chrono>
#include <thread>

#include <catch2/catch_test_macros.hpp>
#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "dds_test_support.hpp"
#include "geometry_msgs/msg/PoseStampedPubSubTypes.hpp"
#include "nav_msgs/msg/OdometryPubSubTypes.hpp"
#include "rsrio_msgs/msg/StatusPubSubTypes.hpp"

namespace fdds = eprosima::fastdds::dds;

namespace {

rsrio::PoseOutput sample_pose() {
  rsrio::PoseOutput p;
  p.stamp_ns = 1763884800123456789LL;
  p.position = {1.0, -2.0, 0.5};
  p.orientation = {0.0, 0.0, 0.38268343236, 0.92387953251};
  p.linear_velocity = {0.8, 0.0, 0.0};
  p.angular_velocity = {0.0, 0.0, -0.2};
  for (int i = 0; i < 36; ++i) p.pose_covariance[static_cast<std::size_t>(i)] = 0.001 * i;
  p.twist_covariance[0] = 0.01;
  return p;
}

}  // namespace

TEST_CASE("odometry message: REP-105 frames, stamp split, covariance passed in ROS order", "[publisher]") {
  rsrio::PublisherOptions o;
  nav_msgs::msg::Odometry m;
  rsrio::to_msg(sample_pose(), o, m);
  CHECK(m.header().frame_id() == "odom");
  CHECK(m.child_frame_id() == "base_link");
  CHECK(m.header().stamp().sec() == 1763884800);
  CHECK(m.header().stamp().nanosec() == 123456789u);
  CHECK(m.pose().pose().orientation().z() == 0.38268343236);
  CHECK(m.pose().covariance()[7] == 0.007);
  CHECK(m.twist().twist().angular().z() == -0.2);

  rsrio::PoseOutput before_epoch = sample_pose();
  before_epoch.stamp_ns = -1;  // builtin_interfaces/Time keeps nanosec in [0, 1e9)
  rsrio::to_msg(before_epoch, o, m);
  CHECK(m.header().stamp().sec() == -1);
  CHECK(m.header().stamp().nanosec() == 999999999u);
}

TEST_CASE("published odometry, pose and status reach a separate participant", "[publisher][dds]") {
  const rsrio::DdsOptions opt = rsrio::testing::loopback_options("odometry_publisher_test");
  rsrio::DdsParticipant daemon_side(opt);
  rsrio::DdsParticipant node_side(opt);
  rsrio::PublisherOptions o;
  o.odom_frame_id = "map";
  rsrio::OdometryPublisher publisher(daemon_side, o);

  auto* odom = node_side.make_reader("rt/rsrio/odom", fdds::TypeSupport(new nav_msgs::msg::OdometryPubSubType()),
                                     rsrio::QosPreset::kOdometry);
  auto* pose = node_side.make_reader("rt/rsrio/pose", fdds::TypeSupport(new geometry_msgs::msg::PoseStampedPubSubType()),
                                     rsrio::QosPreset::kOdometry);
  auto* status = node_side.make_reader("rt/rsrio/status", fdds::TypeSupport(new rsrio_msgs::msg::StatusPubSubType()),
                                       rsrio::QosPreset::kLatched);
  // Wait until both pose readers are matched, on both sides (reliable + volatile: earlier samples
  // are not resent, and a reader can see its match before the writer does).
  for (int i = 0; i < 200; ++i) {
    fdds::SubscriptionMatchedStatus a, b;
    odom->get_subscription_matched_status(a);
    pose->get_subscription_matched_status(b);
    if (a.current_count > 0 && b.current_count > 0 && publisher.pose_subscribers() > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  REQUIRE(publisher.pose_subscribers() > 0);
  REQUIRE(publisher.publish(sample_pose()));
  rsrio_msgs::msg::Status st;
  st.health("ok");
  st.frames_received(42);
  REQUIRE(publisher.publish(st));

  fdds::SampleInfo info;
  REQUIRE(odom->wait_for_unread_message(fdds::Duration_t(10, 0)));
  nav_msgs::msg::Odometry got;
  REQUIRE(odom->take_next_sample(&got, &info) == fdds::RETCODE_OK);
  CHECK(got.header().frame_id() == "map");
  CHECK(got.pose().pose().position().y() == -2.0);
  REQUIRE(pose->wait_for_unread_message(fdds::Duration_t(10, 0)));
  geometry_msgs::msg::PoseStamped got_pose;
  REQUIRE(pose->take_next_sample(&got_pose, &info) == fdds::RETCODE_OK);
  CHECK(got_pose.pose().position().x() == 1.0);
  REQUIRE(status->wait_for_unread_message(fdds::Duration_t(10, 0)));
  rsrio_msgs::msg::Status got_status;
  REQUIRE(status->take_next_sample(&got_status, &info) == fdds::RETCODE_OK);
  CHECK(got_status.frames_received() == 42u);
  CHECK(publisher.write_failures() == 0u);
}
