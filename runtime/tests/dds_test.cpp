// A real Fast DDS round trip on loopback: one participant publishes, another reads back.
#include "rsrio/runtime/dds.hpp"

#include <chrono>
#include <thread>

#include <catch2/catch_test_macros.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "dds_test_support.hpp"
#include "geometry_msgs/msg/PoseStampedPubSubTypes.hpp"
#include "nav_msgs/msg/OdometryPubSubTypes.hpp"

namespace fdds = eprosima::fastdds::dds;

namespace {

bool wait_matched(fdds::DataWriter* w, int count = 1) {
  for (int i = 0; i < 200; ++i) {
    if (rsrio::testing::matched_readers(w) >= count) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

nav_msgs::msg::Odometry make_odometry() {
  nav_msgs::msg::Odometry o;
  o.header().stamp().sec(1763884800);
  o.header().stamp().nanosec(123456789);
  o.header().frame_id("odom");
  o.child_frame_id("base_link");
  o.pose().pose().position().x(1.5);
  o.pose().pose().position().y(-2.25);
  o.pose().pose().position().z(0.125);
  o.pose().pose().orientation().x(0.0);
  o.pose().pose().orientation().y(0.0);
  o.pose().pose().orientation().z(0.38268343236);
  o.pose().pose().orientation().w(0.92387953251);
  for (int i = 0; i < 36; ++i) {
    o.pose().covariance()[i] = (i % 7 == 0) ? 0.01 * (i + 1) : 0.0;
    o.twist().covariance()[i] = (i % 7 == 0) ? 0.001 * (i + 1) : 1e-6 * i;
  }
  o.twist().twist().linear().x(0.8);
  o.twist().twist().angular().z(-0.2);
  return o;
}

}  // namespace

TEST_CASE("ROS 2 type names come out of fastddsgen -typeros2", "[dds]") {
  fdds::TypeSupport odom(new nav_msgs::msg::OdometryPubSubType());
  fdds::TypeSupport pose(new geometry_msgs::msg::PoseStampedPubSubType());
  CHECK(odom.get_type_name() == "nav_msgs::msg::dds_::Odometry_");
  CHECK(pose.get_type_name() == "geometry_msgs::msg::dds_::PoseStamped_");
  CHECK(rsrio::ros_topic_to_dds("/rsrio/odom") == "rt/rsrio/odom");
}

TEST_CASE("Odometry published on loopback is read back intact by another participant", "[dds]") {
  rsrio::DdsParticipant writer_side(rsrio::testing::loopback_options("dds_test_writer"));
  rsrio::DdsParticipant reader_side(rsrio::testing::loopback_options("dds_test_reader"));

  const std::string topic = "rt/rsrio/test_odom";
  auto* writer = writer_side.make_writer(topic, fdds::TypeSupport(new nav_msgs::msg::OdometryPubSubType()),
                                         rsrio::QosPreset::kOdometry);
  auto* reader = reader_side.make_reader(topic, fdds::TypeSupport(new nav_msgs::msg::OdometryPubSubType()),
                                         rsrio::QosPreset::kOdometry);
  REQUIRE(wait_matched(writer));

  const nav_msgs::msg::Odometry sent = make_odometry();
  REQUIRE(writer->write(&sent) == fdds::RETCODE_OK);

  REQUIRE(reader->wait_for_unread_message(fdds::Duration_t(10, 0)));
  nav_msgs::msg::Odometry got;
  fdds::SampleInfo info;
  REQUIRE(reader->take_next_sample(&got, &info) == fdds::RETCODE_OK);
  REQUIRE(info.valid_data);
  CHECK(got == sent);
  CHECK(got.header().frame_id() == "odom");
  CHECK(got.child_frame_id() == "base_link");
  CHECK(got.pose().pose().position().y() == -2.25);
  CHECK(got.twist().covariance()[35] == sent.twist().covariance()[35]);
}

TEST_CASE("latched QoS gives a late subscriber the last sample", "[dds]") {
  const rsrio::DdsOptions opt = rsrio::testing::loopback_options("dds_test");
  rsrio::DdsParticipant writer_side(opt);
  const std::string topic = "rt/rsrio/test_latched_pose";
  auto* writer = writer_side.make_writer(topic, fdds::TypeSupport(new geometry_msgs::msg::PoseStampedPubSubType()),
                                         rsrio::QosPreset::kLatched);
  geometry_msgs::msg::PoseStamped p;
  for (int i = 1; i <= 5; ++i) {
    p.pose().position().x(i);
    REQUIRE(writer->write(&p) == fdds::RETCODE_OK);
  }
  rsrio::DdsParticipant reader_side(opt);
  auto* reader = reader_side.make_reader(topic, fdds::TypeSupport(new geometry_msgs::msg::PoseStampedPubSubType()),
                                         rsrio::QosPreset::kLatched);
  REQUIRE(reader->wait_for_unread_message(fdds::Duration_t(10, 0)));
  geometry_msgs::msg::PoseStamped got;
  fdds::SampleInfo info;
  REQUIRE(reader->take_next_sample(&got, &info) == fdds::RETCODE_OK);
  CHECK(got.pose().position().x() == 5.0);
  CHECK(reader->take_next_sample(&got, &info) != fdds::RETCODE_OK);  // only the last one
}
