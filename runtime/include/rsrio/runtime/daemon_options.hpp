// The daemon's own options (section `daemon:` of its YAML file): where radar and IMU come from,
// where poses go, queue capacities and thread placement. The estimator's options live in their
// own sections (radar:, dsp:, ...), loaded by their stages.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace rsrio {

class OptionsNode;

struct DaemonOptions {
  // Sources. radar_source: "dca1000://BOARD_IP[:HOST_IP]" (live, or the board emulator) or
  // "recording:PATH" (a recording replayed at its own pace, IMU from it too when imu_source is
  // "recording").
  std::string radar_source = "dca1000://192.168.33.180";
  std::string imu_source = "dds";         // dds | recording
  std::string imu_topic = "/imu";         // ROS 2 name; DDS topic rt/imu
  double playback_rate = 1.0;             // recording source: 1 = real time

  // Output (ROS 2 names; REP-105 frames).
  std::string odom_topic = "/rsrio/odom";
  std::string pose_topic = "/rsrio/pose";
  std::string status_topic = "/rsrio/status";
  std::string odom_frame_id = "odom";
  std::string base_frame_id = "base_link";
  std::string map_frame_id = "map";  // the backend's frame (PoseStamped when backend is ba)
  int domain_id = 0;
  bool loopback_only = true;

  // Backend: none (poses from the frontend) | ba (RadarSplat++ bundle adjustment on its own
  // thread; its options are the `backend:` section). With ba, nav_msgs/Odometry stays in the odom
  // frame (continuous, REP-105) and PoseStamped carries the corrected pose in map_frame_id.
  std::string backend = "none";

  // Queues between the stages (explicit capacities; every drop is counted).
  int frame_queue = 4;      // capture -> RIO: raw frames (a frame pool of this size + 1)
  int imu_queue = 2048;     // IMU -> RIO: ~5 s at 400 Hz
  int pose_queue = 64;      // RIO -> publisher
  int event_queue = 256;    // RIO/capture -> log
  int keyframe_queue = 2;   // RIO -> BA: keyframe candidates with their images (one being optimised
                            // plus these; the BA thread takes ~0.4 s per keyframe)

  // Threads. Priority 0 = SCHED_OTHER; rt_required: refuse to run without SCHED_FIFO.
  int capture_priority = 80;
  int rio_priority = 70;
  std::vector<int> capture_cpus;
  std::vector<int> rio_cpus;
  int ba_nice = 10;         // the BA thread: SCHED_OTHER at this nice value, below the RIO thread
  std::vector<int> ba_cpus;
  int thread_stack_kib = 1024;
  bool lock_memory = true;
  bool rt_required = false;

  // Health.
  double radar_timeout_s = 1.0;   // no frame this long: radar stale, driver restarted
  double imu_timeout_s = 0.5;     // no IMU this long: IMU stale
  double imu_wait_s = 0.1;        // a frame waits at most this long for the IMU to reach its time
  double status_period_s = 1.0;
  double shutdown_timeout_s = 5.0;
};

DaemonOptions load_daemon_options(OptionsNode& node);
void print(std::ostream& out, const DaemonOptions& options);

}  // namespace rsrio
