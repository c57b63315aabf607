// rsrio::Pipeline's IMU listener against a real Fast DDS publisher on loopback: the pipeline goes
// away while the daemon's participant (which outlives it in rsriod) keeps receiving IMU samples.
// Runs under the address and thread sanitizers too (label concurrency), which is where a sample
// delivered to a listener that is gone shows.
#include "rsrio/runtime/pipeline.hpp"

#include <atomic>
#include <chrono>
#include <thread>

#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_string.hpp>

#include "dds_test_support.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/runtime/dds.hpp"
#include "sensor_msgs/msg/ImuPubSubTypes.hpp"

namespace fdds = eprosima::fastdds::dds;

TEST_CASE("Pipeline: its IMU reader goes with it while the participant keeps receiving samples",
          "[pipeline][dds]") {
  using rsrio::testing::loopback_options;
  using rsrio::testing::matched_readers;
  rsrio::DdsParticipant daemon_side(loopback_options("pipeline_test_daemon"));
  rsrio::DdsParticipant imu_side(loopback_options("pipeline_test_imu"));
  auto* writer = imu_side.make_writer(rsrio::ros_topic_to_dds("/pipeline_test/imu"),
                                      fdds::TypeSupport(new sensor_msgs::msg::ImuPubSubType()),
                                      rsrio::QosPreset::kSensorData);

  // An IMU at 1 kHz for the whole test, from its own thread (as another process's would arrive).
  std::atomic<bool> stop{false};
  std::atomic<long> published{0};
  std::thread imu([&] {
    sensor_msgs::msg::Imu m;
    m.header().frame_id("imu");
    m.linear_acceleration().z(9.81);
    while (!stop.load()) {
      const long k = published.load();
      m.header().stamp().sec(1000 + static_cast<std::int32_t>(k / 1000));
      m.header().stamp().nanosec(static_cast<std::uint32_t>((k % 1000) * 1'000'000));
      writer->write(&m);
      published.store(k + 1);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });

  rsrio::DaemonOptions options;
  options.radar_source = "dca1000://127.0.0.9";  // never opened: the pipeline is not started
  options.imu_source = "dds";
  options.imu_topic = "/pipeline_test/imu";
  options.domain_id = loopback_options("").domain_id;
  const rsrio::RadarConfig radar = rsrio::radar_preset("xwr1843");
  for (int round = 0; round < 3; ++round) {
    INFO("round " << round);
    {
      rsrio::Pipeline pipeline(options, radar, {}, {}, daemon_side);
      // Its reader matches the writer and samples come in (the listener runs on Fast DDS's threads).
      bool receiving = false;
      for (int i = 0; i < 200 && !receiving; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        receiving = matched_readers(writer) >= 1 && pipeline.snapshot().imu_state == "ok";
      }
      REQUIRE(receiving);
    }  // destroyed while samples keep arriving
    // The participant lives on and the IMU keeps publishing: with the reader left behind, each
    // sample would reach a listener that no longer exists.
    const long before = published.load();
    for (int i = 0; i < 100 && matched_readers(writer) > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    CHECK(matched_readers(writer) == 0);  // the reader is gone, not merely ignored
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    CHECK(published.load() > before + 20);
  }
  stop.store(true);
  imu.join();
}

TEST_CASE("Pipeline: refuses the frontend's whole-run smoother, whose memory grows with the run",
          "[pipeline]") {
  rsrio::DdsParticipant dds(rsrio::testing::loopback_options("pipeline_test_smoother"));
  rsrio::DaemonOptions options;
  options.radar_source = "dca1000://127.0.0.9";  // never opened
  options.imu_source = "dds";
  options.imu_topic = "/pipeline_test/smoother_imu";
  const rsrio::RadarConfig radar = rsrio::radar_preset("xwr1843");
  rsrio::rio::OdometryOptions stage;
  { rsrio::Pipeline accepted(options, radar, stage, {}, dds); }  // the defaults: built and gone
  stage.frontend.whole_run_smoother = true;
  CHECK_THROWS_WITH(rsrio::Pipeline(options, radar, stage, {}, dds),
                    Catch::Matchers::ContainsSubstring("frontend.whole_run_smoother must be false"));
}
