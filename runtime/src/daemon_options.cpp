#include "rsrio/runtime/daemon_options.hpp"

#include <ostream>

#include "rsrio/common/options.hpp"

namespace rsrio {

DaemonOptions load_daemon_options(OptionsNode& node) {
  DaemonOptions o;
  node.read("radar_source", o.radar_source);
  if (o.radar_source.rfind("dca1000://", 0) != 0 && o.radar_source.rfind("recording:", 0) != 0)
    throw ConfigError(node.file(), node.key_path("radar_source"),
                      "dca1000://BOARD_IP[:HOST_IP] or recording:PATH");
  node.read_choice("imu_source", o.imu_source, {"dds", "recording"});
  node.read("imu_topic", o.imu_topic);
  node.read("playback_rate", o.playback_rate, {0.01, 100.0});
  node.read("odom_topic", o.odom_topic);
  node.read("pose_topic", o.pose_topic);
  node.read("status_topic", o.status_topic);
  node.read("odom_frame_id", o.odom_frame_id);
  node.read("base_frame_id", o.base_frame_id);
  node.read("map_frame_id", o.map_frame_id);
  node.read_choice("backend", o.backend, {"none", "ba"});
  node.read("domain_id", o.domain_id, {0, 232});
  node.read("loopback_only", o.loopback_only);
  node.read("frame_queue", o.frame_queue, {1, 64});
  node.read("imu_queue", o.imu_queue, {16, 1 << 16});
  node.read("pose_queue", o.pose_queue, {1, 4096});
  node.read("event_queue", o.event_queue, {16, 1 << 16});
  node.read("keyframe_queue", o.keyframe_queue, {1, 64});
  node.read("capture_priority", o.capture_priority, {0, 99});
  node.read("rio_priority", o.rio_priority, {0, 99});
  node.read("capture_cpus", o.capture_cpus, {0, 1023});
  node.read("rio_cpus", o.rio_cpus, {0, 1023});
  node.read("ba_nice", o.ba_nice, {0, 19});
  node.read("ba_cpus", o.ba_cpus, {0, 1023});
  node.read("thread_stack_kib", o.thread_stack_kib, {64, 65536});
  node.read("lock_memory", o.lock_memory);
  node.read("rt_required", o.rt_required);
  node.read("radar_timeout_s", o.radar_timeout_s, {0.05, 60.0});
  node.read("imu_timeout_s", o.imu_timeout_s, {0.01, 60.0});
  node.read("imu_wait_s", o.imu_wait_s, {0.0, 5.0});
  node.read("status_period_s", o.status_period_s, {0.05, 60.0});
  node.read("shutdown_timeout_s", o.shutdown_timeout_s, {0.1, 60.0});
  for (const auto* topic : {&o.imu_topic, &o.odom_topic, &o.pose_topic, &o.status_topic})
    if (topic->empty() || topic->front() != '/')
      throw ConfigError(node.file(), node.key_path("*_topic"), "a ROS 2 topic name starting with '/'");
  node.finish();
  return o;
}

namespace {
std::string list(const std::vector<int>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "]";
}
}  // namespace

void print(std::ostream& out, const DaemonOptions& o) {
  out << "daemon:\n"
      << "  radar_source: \"" << o.radar_source << "\"\n"
      << "  imu_source: " << o.imu_source << "\n"
      << "  imu_topic: " << o.imu_topic << "\n"
      << "  playback_rate: " << o.playback_rate << "\n"
      << "  odom_topic: " << o.odom_topic << "\n"
      << "  pose_topic: " << o.pose_topic << "\n"
      << "  status_topic: " << o.status_topic << "\n"
      << "  odom_frame_id: " << o.odom_frame_id << "\n"
      << "  base_frame_id: " << o.base_frame_id << "\n"
      << "  map_frame_id: " << o.map_frame_id << "\n"
      << "  backend: " << o.backend << "\n"
      << "  domain_id: " << o.domain_id << "\n"
      << "  loopback_only: " << (o.loopback_only ? "true" : "false") << "\n"
      << "  frame_queue: " << o.frame_queue << "\n"
      << "  imu_queue: " << o.imu_queue << "\n"
      << "  pose_queue: " << o.pose_queue << "\n"
      << "  event_queue: " << o.event_queue << "\n"
      << "  keyframe_queue: " << o.keyframe_queue << "\n"
      << "  capture_priority: " << o.capture_priority << "\n"
      << "  rio_priority: " << o.rio_priority << "\n"
      << "  capture_cpus: " << list(o.capture_cpus) << "\n"
      << "  rio_cpus: " << list(o.rio_cpus) << "\n"
      << "  ba_nice: " << o.ba_nice << "\n"
      << "  ba_cpus: " << list(o.ba_cpus) << "\n"
      << "  thread_stack_kib: " << o.thread_stack_kib << "\n"
      << "  lock_memory: " << (o.lock_memory ? "true" : "false") << "\n"
      << "  rt_required: " << (o.rt_required ? "true" : "false") << "\n"
      << "  radar_timeout_s: " << o.radar_timeout_s << "\n"
      << "  imu_timeout_s: " << o.imu_timeout_s << "\n"
      << "  imu_wait_s: " << o.imu_wait_s << "\n"
      << "  status_period_s: " << o.status_period_s << "\n"
      << "  shutdown_timeout_s: " << o.shutdown_timeout_s << "\n";
}

}  // namespace rsrio
