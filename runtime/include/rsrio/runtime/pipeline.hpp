// The daemon's pipeline: the stages of SPEC Sec. 2 as threads joined by bounded SPSC queues.
//
//   capture thread (SCHED_FIFO)           RIO thread (SCHED_FIFO)             publisher thread
//   DCA1000 driver | recording  --frames-->  decode, DSP, ego-velocity,  --poses-->  DDS Odometry,
//   (raw bytes into a frame pool)  <--free--  IMU preintegration, window            PoseStamped, Status,
//   IMU from the recording    ---imu----->   (OdometryStage)             --events-> the log
//   IMU from DDS (Fast DDS thread) --imu-->
//
// Real-time discipline: the capture thread neither allocates, locks, logs nor touches DDS; it
// copies a finished frame into a preallocated slot and pushes its index. The RIO thread takes no
// lock, never logs (it pushes small events) and never writes DDS (it pushes poses). It does run
// GTSAM, which allocates inside its optimiser; that is why the RIO thread's input is a queue with
// a drop policy rather than the receive loop itself: a slow optimisation drops (and counts) a frame,
// it never delays a datagram.
//
// Drop policies (each counted in the status):
//   frames: the capture side drops the NEWEST frame when no slot is free (the RIO thread is behind);
//   IMU:    the producer drops the newest sample when the queue is full;
//   poses:  the RIO thread drops the newest pose when the publisher is behind;
//   events: dropped when full (the count of dropped events is itself reported).
// Shutdown: request_stop() sets one flag every loop checks at least every 50 ms; stop() joins
// within DaemonOptions::shutdown_timeout_s.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/runtime/daemon_options.hpp"
#include "rsrio/runtime/odometry_publisher.hpp"
#include "rsrio/runtime/odometry_stage.hpp"
#include "rsrio/splat/backend.hpp"
#include "rsrio_msgs/msg/Status.hpp"

namespace rsrio {

class DdsParticipant;

/// Distribution of one timing over the run (ms).
struct TimingSummary {
  double p50 = 0, p99 = 0, max = 0, mean = 0;
  std::uint64_t samples = 0;
};

/// The daemon's timings over the run (benchmarks; rsriod logs them at exit).
struct PipelineTimings {
  TimingSummary latency;     // frame complete -> odometry written to DDS
  TimingSummary rio_pickup;  // frame complete -> taken by the RIO thread (scheduling + queue wait)
  TimingSummary rio_busy;    // the RIO thread's work on the frame (decode, DSP, ego-velocity, frontend)
  TimingSummary ba;          // bundle adjustment per keyframe (backend ba)
};

/// The pipeline's health at one moment (a copy; any thread).
struct PipelineSnapshot {
  std::string radar_state;   // "waiting", "streaming", "stale", "restarting", "error: ...", "finished"
  std::string imu_state;     // "waiting", "ok", "stale"
  bool streaming = false;    // at least one frame arrived since start (READY=1)
  bool source_finished = false;  // recording source: every message was read
  bool drained = false;      // source finished and every queued frame and pose handled
  std::uint64_t rio_heartbeat = 0;
};

class Pipeline {
 public:
  /// `radar` is the configuration of the live radar (for a recording it is taken from the
  /// recording's first frame and must match). Throws ConfigError / std::runtime_error for a
  /// source that cannot be opened, std::invalid_argument for a stage with
  /// frontend.whole_run_smoother (unbounded in a running pipeline).
  Pipeline(const DaemonOptions& options, const RadarConfig& radar, const rio::OdometryOptions& stage,
           const splat::BackendOptions& backend, DdsParticipant& dds);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Starts the threads (then locks memory if asked). Throws std::runtime_error when rt_required
  /// and SCHED_FIFO was refused.
  void start();
  void request_stop();
  /// Joins every thread (it always waits for them: a detached thread would outlive the objects it
  /// uses); false when that took longer than DaemonOptions::shutdown_timeout_s, so the caller can
  /// report the overrun.
  bool stop();

  PipelineSnapshot snapshot() const;
  /// After stop(): the timings of the run.
  PipelineTimings timings() const;
  /// Called on the publisher thread for every pose after it was written (tests, rsriod progress).
  void on_pose(std::function<void(const PoseOutput&)> callback);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsrio
