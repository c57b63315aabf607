// Test helper: publishes sensor_msgs/Imu on a DDS topic (the IMU a recorder subscribes to) until
// SIGTERM, sample k carrying angular_velocity.x = k so that a reader can check order and gaps.
// usage: publish_imu TOPIC RATE_HZ   (domain from ROS_DOMAIN_ID); prints "published=N" on exit.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "rsrio/runtime/dds.hpp"
#include "sensor_msgs/msg/ImuPubSubTypes.hpp"

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }
}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  if (argc != 3) {
    std::fprintf(stderr, "usage: publish_imu TOPIC RATE_HZ\n");
    return 2;
  }
  rsrio::DdsOptions options;
  options.participant_name = "publish_imu";
  if (const char* d = std::getenv("ROS_DOMAIN_ID")) options.domain_id = std::atoi(d);
  rsrio::DdsParticipant participant(options);
  auto* writer = participant.make_writer(argv[1], eprosima::fastdds::dds::TypeSupport(new sensor_msgs::msg::ImuPubSubType()),
                                         rsrio::QosPreset::kSensorData);
  const auto period = std::chrono::duration<double>(1.0 / std::atof(argv[2]));
  const auto start = std::chrono::steady_clock::now();
  long published = 0;
  sensor_msgs::msg::Imu m;
  m.header().frame_id("imu");
  m.orientation_covariance()[0] = -1;
  m.linear_acceleration().z(9.81);
  while (!g_stop.load()) {
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                        std::chrono::system_clock::now().time_since_epoch()).count();
    m.header().stamp().sec(static_cast<std::int32_t>(ns / 1'000'000'000));
    m.header().stamp().nanosec(static_cast<std::uint32_t>(ns % 1'000'000'000));
    m.angular_velocity().x(static_cast<double>(published));
    writer->write(&m);
    ++published;
    std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(period * published));
  }
  std::printf("published=%ld\n", published);
  return 0;
}
