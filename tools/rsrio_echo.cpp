// rsrio-echo: prints what rsriod publishes (odometry and status), the way `ros2 topic echo` would,
// from a separate process over real DDS. Optionally writes the received poses as a TUM trajectory
// (the end-to-end tests compare it with ground truth).
//
// Exit codes: 0 when --count odometry messages arrived (or, without --count, at --duration / a
// signal), 1 when fewer arrived before the time ran out, 2 on a bad command line.
#include <atomic>
#include <cmath>
#include <csignal>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <thread>

#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "geometry_msgs/msg/PoseStampedPubSubTypes.hpp"
#include "nav_msgs/msg/OdometryPubSubTypes.hpp"
#include "rsrio/common/cli.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/runtime/dds.hpp"
#include "rsrio_msgs/msg/StatusPubSubTypes.hpp"

namespace fdds = eprosima::fastdds::dds;

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Echo : fdds::DataReaderListener {
  std::mutex mutex;
  std::ofstream tum, pose_tum;
  bool quiet = false;
  bool show_status = false;
  std::atomic<std::uint64_t> odometry{0};
  std::atomic<std::uint64_t> poses{0};

  static void write_tum(std::ofstream& out, double t, const geometry_msgs::msg::Pose& pose) {
    const auto& p = pose.position();
    const auto& q = pose.orientation();
    out << std::fixed << std::setprecision(9) << t << ' ' << p.x() << ' ' << p.y() << ' ' << p.z() << ' ' << q.x()
        << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << std::endl;  // whole lines for readers
  }

  void on_data_available(fdds::DataReader* reader) override {
    std::lock_guard<std::mutex> lock(mutex);
    fdds::SampleInfo info;
    if (reader->type().get_type_name() == "nav_msgs::msg::dds_::Odometry_") {
      nav_msgs::msg::Odometry o;
      while (reader->take_next_sample(&o, &info) == fdds::RETCODE_OK) {
        if (!info.valid_data) continue;
        const double t = o.header().stamp().sec() + 1e-9 * o.header().stamp().nanosec();
        const auto& p = o.pose().pose().position();
        const auto& q = o.pose().pose().orientation();
        if (tum.is_open()) write_tum(tum, t, o.pose().pose());
        if (!quiet) {
          const double yaw = std::atan2(2 * (q.w() * q.z() + q.x() * q.y()), 1 - 2 * (q.y() * q.y() + q.z() * q.z()));
          std::cout << std::fixed << std::setprecision(3) << "odom " << t << "  " << o.header().frame_id() << "->"
                    << o.child_frame_id() << "  x " << p.x() << " y " << p.y() << " z " << p.z() << "  yaw "
                    << yaw * 180 / M_PI << " deg  v " << o.twist().twist().linear().x() << " m/s\n";
        }
        odometry.fetch_add(1);
      }
    } else if (reader->type().get_type_name() == "geometry_msgs::msg::dds_::PoseStamped_") {
      geometry_msgs::msg::PoseStamped m;
      while (reader->take_next_sample(&m, &info) == fdds::RETCODE_OK) {
        if (!info.valid_data) continue;
        if (pose_tum.is_open())
          write_tum(pose_tum, m.header().stamp().sec() + 1e-9 * m.header().stamp().nanosec(), m.pose());
        poses.fetch_add(1);
      }
    } else {
      rsrio_msgs::msg::Status s;
      while (reader->take_next_sample(&s, &info) == fdds::RETCODE_OK) {
        if (!info.valid_data || !show_status) continue;
        std::cout << "status level " << int(s.level()) << " \"" << s.health() << "\" radar " << s.radar_state()
                  << " imu " << s.imu_state() << " frames " << s.frames_received() << " damaged "
                  << s.frames_damaged() << " dropped " << s.frames_dropped() << " lost packets " << s.packets_lost()
                  << " latency p50 " << s.latency_p50_ms() << " ms p99 " << s.latency_p99_ms() << " ms";
        if (s.keyframes() > 0)
          std::cout << " keyframes " << s.keyframes() << " gaussians " << s.gaussians() << " ba " << s.ba_time_ms()
                    << " ms";
        for (const auto& q : s.queues())
          if (q.dropped() > 0) std::cout << " " << q.name() << "-queue drops " << q.dropped();
        std::cout << "\n";
      }
    }
    std::cout.flush();
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string odom_topic = "/rsrio/odom", pose_topic = "/rsrio/pose", status_topic = "/rsrio/status", domain = "0",
              count_s, duration_s = "0", tum_path, pose_tum_path;
  bool quiet = false, status = false, all_interfaces = false;
  rsrio::Cli cli("rsrio-echo", "Print rsriod's odometry and status received over DDS.");
  cli.option("--odom-topic", "NAME", "ROS 2 odometry topic (default /rsrio/odom)", &odom_topic)
      .option("--status-topic", "NAME", "ROS 2 status topic (default /rsrio/status)", &status_topic)
      .option("--domain", "ID", "DDS domain (default 0)", &domain)
      .option("--count", "N", "exit 0 after N odometry messages", &count_s)
      .option("--duration", "S", "give up after S seconds (0: run until a signal)", &duration_s)
      .option("--pose-topic", "NAME", "ROS 2 PoseStamped topic (default /rsrio/pose)", &pose_topic)
      .option("--tum", "FILE", "write the received odometry poses as a TUM trajectory", &tum_path)
      .option("--pose-tum", "FILE", "write the received PoseStamped poses (with the backend: the map-frame pose)",
              &pose_tum_path)
      .flag("--status", "print the status messages too", &status)
      .flag("--quiet", "print nothing per message", &quiet)
      .flag("--all-interfaces", "DDS on every interface (default: loopback only, as rsriod)", &all_interfaces);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  if (auto rc = rsrio::load_program_config(cli, "rsrio-echo", [](rsrio::OptionsNode&) {})) return *rc;
  std::uint64_t count = 0;
  double duration = 0;
  rsrio::DdsOptions dds_options;
  try {
    if (!count_s.empty()) count = std::stoull(count_s);
    duration = std::stod(duration_s);
    dds_options.domain_id = std::stoi(domain);
  } catch (const std::exception&) {
    return cli.usage_error("--count, --duration and --domain take numbers");
  }
  dds_options.loopback_only = !all_interfaces;
  dds_options.participant_name = "rsrio-echo";

  Echo echo;
  echo.quiet = quiet;
  echo.show_status = status;
  if (!tum_path.empty()) {
    echo.tum.open(tum_path);
    if (!echo.tum) {
      std::cerr << "rsrio-echo: error: cannot write " << tum_path << "\n";
      return 1;
    }
  }
  if (!pose_tum_path.empty()) {
    echo.pose_tum.open(pose_tum_path);
    if (!echo.pose_tum) {
      std::cerr << "rsrio-echo: error: cannot write " << pose_tum_path << "\n";
      return 1;
    }
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    rsrio::DdsParticipant dds(dds_options);
    dds.make_reader(rsrio::ros_topic_to_dds(odom_topic), fdds::TypeSupport(new nav_msgs::msg::OdometryPubSubType()),
                    rsrio::QosPreset::kOdometry, &echo);
    if (!pose_tum_path.empty())
      dds.make_reader(rsrio::ros_topic_to_dds(pose_topic),
                      fdds::TypeSupport(new geometry_msgs::msg::PoseStampedPubSubType()), rsrio::QosPreset::kOdometry,
                      &echo);
    dds.make_reader(rsrio::ros_topic_to_dds(status_topic), fdds::TypeSupport(new rsrio_msgs::msg::StatusPubSubType()),
                    rsrio::QosPreset::kLatched, &echo);
    const auto start = std::chrono::steady_clock::now();
    while (!g_stop) {
      if (count && echo.odometry.load() >= count) break;
      if (duration > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > duration)
        break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    // Delete the readers (with the participant) before the listener goes away.
  } catch (const std::exception& e) {
    std::cerr << "rsrio-echo: error: " << e.what() << "\n";
    return 1;
  }
  std::lock_guard<std::mutex> lock(echo.mutex);
  echo.tum.flush();
  echo.pose_tum.flush();
  std::cerr << "rsrio-echo: " << echo.odometry.load() << " odometry messages\n";
  return (count && echo.odometry.load() < count) ? 1 : 0;
}
