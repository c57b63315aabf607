#include "rsrio/runtime/pipeline.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fastdds/dds/subscriber/DataReader.hpp>
#include <tbb/global_control.h>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include <spdlog/spdlog.h>

#include "rsrio/common/log.hpp"
#include "rsrio/common/spsc_queue.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/driver/dca1000_driver.hpp"
#include "rsrio/recording/recording.hpp"
#include "rsrio/runtime/dds.hpp"
#include "rsrio/runtime/keyframe_handoff.hpp"
#include "rsrio/runtime/realtime.hpp"
#include "rsrio/splat/backend.hpp"
#include "sensor_msgs/msg/ImuPubSubTypes.hpp"

namespace fdds = eprosima::fastdds::dds;

namespace rsrio {
namespace {

using Clock = std::chrono::steady_clock;

// A finished frame in the pool, as it crosses from the capture thread to the RIO thread.
struct FrameRef {
  std::uint32_t slot = 0;
  std::uint32_t flags = 0;
  std::uint64_t frame_number = 0;
  std::int64_t stamp_ns = 0;          // wall clock (header stamp)
  std::int64_t complete_mono_ns = 0;  // CLOCK_MONOTONIC at completion
};

// Something worth a log line, made where logging is not allowed.
struct Event {
  enum Code : std::uint8_t {
    kRadarStreaming, kRadarStale, kRadarError, kRecordingEnd, kRecordingDamage, kFrameDamaged,
    kFrameDropped, kDecodeError, kImuStale, kImuBack, kProcessingError, kConfigMismatch, kBackendError
  };
  Code code = kRadarStreaming;
  std::int64_t value = 0;
  std::array<char, 160> text{};
};

std::string_view describe(Event::Code c) {
  switch (c) {
    case Event::kRadarStreaming: return "radar streaming";
    case Event::kRadarStale: return "radar stale: no frame within the timeout, restarting the capture";
    case Event::kRadarError: return "radar capture failed";
    case Event::kRecordingEnd: return "recording finished";
    case Event::kRecordingDamage: return "recording damaged, stopped reading";
    case Event::kFrameDamaged: return "damaged frame (zero-filled bytes), not used";
    case Event::kFrameDropped: return "frame dropped: the RIO thread is behind (frame queue full)";
    case Event::kDecodeError: return "frame could not be decoded";
    case Event::kImuStale: return "IMU stale: no sample within the timeout";
    case Event::kImuBack: return "IMU back";
    case Event::kProcessingError: return "processing failed for a frame";
    case Event::kConfigMismatch: return "frame's radar configuration differs from the daemon's";
    case Event::kBackendError: return "bundle adjustment failed for a keyframe";
  }
  return "?";
}

std::int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

rio::ImuSample to_sample(const sensor_msgs::msg::Imu& m) {
  rio::ImuSample s;
  s.t = m.header().stamp().sec() + 1e-9 * m.header().stamp().nanosec();
  s.accel = {m.linear_acceleration().x(), m.linear_acceleration().y(), m.linear_acceleration().z()};
  s.gyro = {m.angular_velocity().x(), m.angular_velocity().y(), m.angular_velocity().z()};
  return s;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const std::size_t k = static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(q * v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// A batch over the whole run keeps every factor and state: in a daemon its memory and its solve
// would grow without bound. rsriod refuses it in its options file already; this is the pipeline's
// own guard, for any other program that builds one.
const rio::OdometryOptions& daemon_stage(const rio::OdometryOptions& stage) {
  if (stage.frontend.whole_run_smoother)
    throw std::invalid_argument(
        "Pipeline: frontend.whole_run_smoother must be false in a running pipeline (the whole run as one batch is "
        "rsrio-replay's end of run)");
  return stage;
}

}  // namespace

struct Pipeline::Impl : fdds::DataReaderListener {
  DaemonOptions options;
  RadarConfig radar;
  rio::OdometryOptions stage_options;
  splat::BackendOptions backend_options;
  DdsParticipant& dds;
  // Made here, on the caller's thread: the threads find everything allocated.
  std::unique_ptr<OdometryStage> odometry_stage;
  std::unique_ptr<splat::Backend> backend;     // null: backend none
  std::unique_ptr<KeyframeHandoff> keyframes;  // RIO -> BA
  SpscQueue<splat::OdomCorrection> corrections{8};  // BA -> publisher (latest wins)
  PublisherOptions publisher_options;
  std::unique_ptr<OdometryPublisher> publisher;

  // Frame pool: raw bytes, as the hardware delivers them.
  std::size_t frame_bytes = 0;
  std::vector<std::vector<std::uint8_t>> pool;
  SpscQueue<FrameRef> frames;          // capture -> RIO
  SpscQueue<std::uint32_t> free_slots;  // RIO -> capture
  SpscQueue<rio::ImuSample> imu;       // IMU producer -> RIO
  SpscQueue<PoseOutput> poses;         // RIO -> publisher
  SpscQueue<Event> capture_events;     // capture -> publisher (log)
  SpscQueue<Event> rio_events;         // RIO -> publisher (log)
  std::mutex imu_producer_mutex;       // Fast DDS may call the listener from several threads

  std::atomic<bool> stop_flag{false};
  std::atomic<bool> streaming{false};
  std::atomic<bool> source_finished{false};
  std::atomic<bool> rio_done{false};
  std::atomic<bool> publisher_done{false};
  // The backend's figures for the status (BA thread writes).
  std::atomic<std::uint64_t> ba_keyframes{0}, ba_gaussians{0}, ba_errors{0}, ba_nan_guards{0};
  std::atomic<double> ba_last_ms{0};
  std::atomic<std::uint64_t> heartbeat{0};
  std::atomic<int> radar_state{0};  // 0 waiting, 1 streaming, 2 stale, 3 error, 4 finished
  std::atomic<std::int64_t> last_imu_mono_ns{0};
  std::atomic<std::int64_t> last_frame_mono_ns{0};

  // Counters (atomics: written by one thread, read by the publisher for the status).
  std::atomic<std::uint64_t> frames_received{0}, frames_damaged{0}, frames_dropped{0}, packets_lost{0},
      decode_errors{0}, imu_received{0}, imu_dropped{0}, poses_made{0}, radar_restarts{0},
      processing_errors{0}, events_dropped{0};

  std::function<void(const PoseOutput&)> pose_callback;
  fdds::DataReader* imu_reader = nullptr;

  // GTSAM linearizes on TBB workers; those would be spawned by the RIO thread and inherit its
  // SCHED_FIFO priority and CPU set. One thread: the RIO thread optimises itself, nothing else
  // runs at its priority behind its back.
  tbb::global_control single_threaded_gtsam{tbb::global_control::max_allowed_parallelism, 1};
  RtThread capture_thread, rio_thread, publisher_thread, ba_thread;
  std::vector<double> latencies_ms, pickup_ms, busy_ms;  // publisher thread only (read after join)
  std::vector<double> ba_ms;                              // BA thread only (read after join)
  std::uint64_t status_received = 0, status_damaged = 0;  // at the last status (publisher thread)

  Impl(const DaemonOptions& o, const RadarConfig& r, const rio::OdometryOptions& s, const splat::BackendOptions& b,
       DdsParticipant& d)
      : options(o), radar(r), stage_options(s), backend_options(b), dds(d),
        frame_bytes(raw_frame_bytes(r)),
        frames(static_cast<std::size_t>(o.frame_queue)),
        free_slots(static_cast<std::size_t>(o.frame_queue) + 1),
        imu(static_cast<std::size_t>(o.imu_queue)),
        poses(static_cast<std::size_t>(o.pose_queue)),
        capture_events(static_cast<std::size_t>(o.event_queue)),
        rio_events(static_cast<std::size_t>(o.event_queue)) {
    publisher_options.odom_topic = o.odom_topic;
    publisher_options.pose_topic = o.pose_topic;
    publisher_options.status_topic = o.status_topic;
    publisher_options.odom_frame_id = o.odom_frame_id;
    publisher_options.base_frame_id = o.base_frame_id;
    publisher_options.map_frame_id = o.map_frame_id;
    odometry_stage = std::make_unique<OdometryStage>(r, s);
    if (o.backend == "ba") {
      splat::take_frontend_options(backend_options, s);
      const DspGrids& grids = odometry_stage->odometry().dsp().grids();
      backend = std::make_unique<splat::Backend>(r, grids, backend_options);
      backend->set_cancel_flag(&stop_flag);  // SIGTERM during BA: the stage ends at its next iteration
      const auto max_points = static_cast<std::size_t>(s.dsp.cfar.max_detections) *
                              static_cast<std::size_t>(s.dsp.max_angle_peaks);
      keyframes = std::make_unique<KeyframeHandoff>(
          static_cast<std::size_t>(o.keyframe_queue), static_cast<std::size_t>(grids.range_bins * grids.azimuth_bins),
          static_cast<std::size_t>(grids.range_bins * grids.doppler_bins), max_points, backend_options);
    }
    // One slot more than the queue holds: the RIO thread works on one while the queue is full.
    pool.resize(static_cast<std::size_t>(o.frame_queue) + 1);
    for (std::uint32_t i = 0; i < pool.size(); ++i) {
      pool[i].assign(frame_bytes, 0);
      free_slots.try_push(i);
    }
    for (auto* v : {&latencies_ms, &pickup_ms, &busy_ms, &ba_ms}) v->reserve(1 << 16);  // ~1.8 h at 10 Hz
  }

  void event(SpscQueue<Event>& q, Event::Code code, std::int64_t value = 0, const char* text = nullptr) {
    Event e;
    e.code = code;
    e.value = value;
    if (text) std::strncpy(e.text.data(), text, e.text.size() - 1);
    if (!q.try_push(e)) events_dropped.fetch_add(1, std::memory_order_relaxed);
  }

  // ---- capture side --------------------------------------------------------------------------
  // Hands one frame of raw bytes to the RIO thread (drop-newest when no slot is free).
  void hand_over(std::span<const std::uint8_t> bytes, std::uint64_t number, std::uint32_t flags,
                 std::int64_t stamp_ns, std::int64_t mono_ns) {
    frames_received.fetch_add(1, std::memory_order_relaxed);
    last_frame_mono_ns.store(mono_ns, std::memory_order_relaxed);
    if (flags & kFrameDamaged) frames_damaged.fetch_add(1, std::memory_order_relaxed);
    std::uint32_t slot = 0;
    if (!free_slots.try_pop(slot)) {
      frames_dropped.fetch_add(1, std::memory_order_relaxed);
      event(capture_events, Event::kFrameDropped, static_cast<std::int64_t>(number));
      return;
    }
    std::memcpy(pool[slot].data(), bytes.data(), std::min(bytes.size(), frame_bytes));
    FrameRef ref{slot, flags, number, stamp_ns, mono_ns};
    frames.try_push(ref);  // cannot fail: there are no more refs than slots
    if (!streaming.exchange(true)) event(capture_events, Event::kRadarStreaming);
    radar_state.store(1, std::memory_order_relaxed);
  }

  bool sleep_unless_stopped(std::chrono::milliseconds total) {
    const auto end = Clock::now() + total;
    while (Clock::now() < end) {
      if (stop_flag.load(std::memory_order_relaxed)) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return !stop_flag.load(std::memory_order_relaxed);
  }

  void capture_dca1000() {
    // dca1000://BOARD[:HOST]
    const std::string spec = options.radar_source.substr(std::strlen("dca1000://"));
    const auto colon = spec.find(':');
    Dca1000Options d;
    d.board = Endpoint::parse(spec.substr(0, colon), dca1000::kConfigPort);
    if (colon != std::string::npos) {
      const Endpoint host = Endpoint::parse(spec.substr(colon + 1), dca1000::kConfigPort);
      d.host_config = {host.ip, dca1000::kConfigPort};
      d.host_data = {host.ip, dca1000::kDataPort};
    }
    d.pool_frames = 6;
    const auto stale = std::chrono::nanoseconds(static_cast<std::int64_t>(options.radar_timeout_s * 1e9));
    while (!stop_flag.load(std::memory_order_relaxed)) {
      // (Re)start: allocation is allowed here, it is not the steady state.
      std::unique_ptr<Dca1000Driver> driver;
      try {
        driver = std::make_unique<Dca1000Driver>(d, frame_bytes);
        driver->start();
      } catch (const std::exception& e) {
        radar_state.store(3, std::memory_order_relaxed);
        event(capture_events, Event::kRadarError, 0, e.what());
        radar_restarts.fetch_add(1, std::memory_order_relaxed);
        if (!sleep_unless_stopped(std::chrono::milliseconds(1000))) break;
        continue;
      }
      const std::int64_t offset = driver->realtime_offset_ns();
      std::int64_t last = monotonic_ns();
      std::uint64_t lost_before = 0;
      while (!stop_flag.load(std::memory_order_relaxed)) {
        driver->poll(std::chrono::milliseconds(20));
        driver->poll_config();
        while (AssembledFrame* f = driver->next_frame()) {
          hand_over(f->bytes, f->frame_number, f->flags, f->completed_ns + offset, f->completed_ns);
          last = f->completed_ns;
          driver->release(f);
        }
        const std::uint64_t lost = driver->assembler_counters().lost_packets;
        packets_lost.fetch_add(lost - lost_before, std::memory_order_relaxed);
        lost_before = lost;
        if (monotonic_ns() - last > stale.count()) {
          radar_state.store(2, std::memory_order_relaxed);
          event(capture_events, Event::kRadarStale);
          radar_restarts.fetch_add(1, std::memory_order_relaxed);
          break;
        }
      }
      driver->stop();
    }
  }

  // A recording replayed at its own pace: radar frames and (when imu_source is "recording") IMU.
  void capture_recording() {
    const std::string path = options.radar_source.substr(std::strlen("recording:"));
    RecordingReader reader(path);
    RecordedMessage m;
    rsrio_msgs::msg::RadarFrame frame;
    sensor_msgs::msg::Imu imu_msg;
    const bool imu_from_recording = options.imu_source == "recording";
    std::int64_t first_log = -1;
    const auto start = Clock::now();
    while (!stop_flag.load(std::memory_order_relaxed) && reader.next(m)) {
      if (first_log < 0) first_log = static_cast<std::int64_t>(m.log_time_ns);
      const auto due = start + std::chrono::nanoseconds(static_cast<std::int64_t>(
                                   (static_cast<std::int64_t>(m.log_time_ns) - first_log) / options.playback_rate));
      while (Clock::now() < due && !stop_flag.load(std::memory_order_relaxed))
        std::this_thread::sleep_for(std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(20)));
      if (m.topic == "/imu" && imu_from_recording && decode(m, imu_msg)) {
        push_imu(to_sample(imu_msg));
      } else if (m.schema_name == "rsrio_msgs/msg/RadarFrame" && decode(m, frame)) {
        if (frame.adc().size() != frame_bytes) {
          decode_errors.fetch_add(1, std::memory_order_relaxed);
          event(capture_events, Event::kConfigMismatch, static_cast<std::int64_t>(frame.frame_number()));
          continue;
        }
        const std::int64_t stamp =
            std::int64_t(frame.header().stamp().sec()) * 1000000000 + frame.header().stamp().nanosec();
        hand_over(frame.adc(), frame.frame_number(), frame.flags(), stamp, monotonic_ns());
      }
    }
    if (reader.damage()) event(capture_events, Event::kRecordingDamage, 0, reader.damage()->message().c_str());
    else event(capture_events, Event::kRecordingEnd);
    radar_state.store(4, std::memory_order_relaxed);
    source_finished.store(true);
  }

  void push_imu(rio::ImuSample s) {
    imu_received.fetch_add(1, std::memory_order_relaxed);
    last_imu_mono_ns.store(monotonic_ns(), std::memory_order_relaxed);
    if (!imu.try_push(s)) imu_dropped.fetch_add(1, std::memory_order_relaxed);
  }

  // Fast DDS listener (IMU over DDS).
  void on_data_available(fdds::DataReader* reader) override {
    std::lock_guard<std::mutex> lock(imu_producer_mutex);  // producer side only; not an RT thread
    sensor_msgs::msg::Imu m;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&m, &info) == fdds::RETCODE_OK)
      if (info.valid_data) push_imu(to_sample(m));
  }

  // ---- RIO thread ------------------------------------------------------------------------------
  void rio_loop() {
    OdometryStage& stage = *odometry_stage;
    AdcCube cube = AdcCube::for_config(radar);
    PoseOutput out;
    rio::ImuSample s;
    FrameRef ref;
    bool pending = false;        // a frame waiting for the IMU to reach its time
    std::int64_t pending_since = 0;
    double latest_imu_t = -1e300;
    const auto imu_wait_ns = static_cast<std::int64_t>(options.imu_wait_s * 1e9);
    while (true) {
      heartbeat.fetch_add(1, std::memory_order_relaxed);
      while (imu.try_pop(s)) {
        stage.add_imu(s);
        latest_imu_t = s.t;
      }
      if (!pending && frames.try_pop(ref)) {
        pending = true;
        pending_since = monotonic_ns();
      }
      if (pending) {
        // The frontend integrates the IMU up to the frame's time: wait (briefly, bounded) until the
        // IMU has arrived that far; IMU over DDS may trail the radar by a few milliseconds.
        const bool imu_there = latest_imu_t >= 1e-9 * static_cast<double>(ref.stamp_ns);
        if (imu_there || monotonic_ns() - pending_since > imu_wait_ns || source_finished.load()) {
          pending = false;
          out.rio_pickup_mono_ns = pending_since;
          process(stage, ref, cube, out);
          continue;
        }
      }
      if (!pending) {
        if (stop_flag.load(std::memory_order_relaxed)) break;
        if (source_finished.load(std::memory_order_acquire) && frames.size() == 0) break;
      } else if (stop_flag.load(std::memory_order_relaxed)) {
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    rio_done.store(true, std::memory_order_release);
  }

  void process(OdometryStage& stage, const FrameRef& ref, AdcCube& cube, PoseOutput& out) {
    out.rio_start_mono_ns = monotonic_ns();
    const bool damaged = ref.flags & kFrameDamaged;
    bool ok = false;
    if (!damaged) {
      try {
        decode_frame(radar, pool[ref.slot], cube);
        ok = true;
      } catch (const std::exception&) {
        decode_errors.fetch_add(1, std::memory_order_relaxed);
        event(rio_events, Event::kDecodeError, static_cast<std::int64_t>(ref.frame_number));
      }
    } else {
      event(rio_events, Event::kFrameDamaged, static_cast<std::int64_t>(ref.frame_number));
    }
    std::uint32_t slot = ref.slot;
    free_slots.try_push(slot);
    if (!ok) return;
    try {
      out.stamp_ns = ref.stamp_ns;
      out.frame_complete_mono_ns = ref.complete_mono_ns;
      out.frame_number = ref.frame_number;
      if (stage.add_frame(1e-9 * static_cast<double>(ref.stamp_ns), cube, out)) {
        poses_made.fetch_add(1, std::memory_order_relaxed);
        // A keyframe candidate is copied into a preallocated slot (full: dropped, counted there).
        if (keyframes)
          keyframes->offer(stage.last_t(), Eigen::Isometry3d(stage.last_odom_T_body().matrix()), stage.dsp_result());
        out.rio_end_mono_ns = monotonic_ns();
        poses.try_push(out);  // full: newest dropped, counted by the queue
      }
    } catch (const std::exception& e) {
      processing_errors.fetch_add(1, std::memory_order_relaxed);
      event(rio_events, Event::kProcessingError, static_cast<std::int64_t>(ref.frame_number), e.what());
    }
  }

  // ---- BA thread (SCHED_OTHER, niced) ---------------------------------------------------------
  // Allocation, locks and time are allowed here: nothing real-time waits for this thread.
  void ba_loop() {
    while (true) {
      if (KeyframeCandidate* c = keyframes->next()) {
        try {
          const auto start = Clock::now();
          if (keyframes->hand_to_backend(c, *backend)) {
            const splat::BackendStats& st = backend->stats();
            ba_last_ms.store(1e3 * std::chrono::duration<double>(Clock::now() - start).count());
            if (ba_ms.size() < ba_ms.capacity()) ba_ms.push_back(ba_last_ms.load());
            ba_keyframes.store(st.keyframes);
            ba_gaussians.store(st.gaussians);
            ba_nan_guards.store(st.nan_guard_hits);
            splat::OdomCorrection corr = backend->correction();
            corrections.try_push(corr);  // full: the publisher is behind; a later one follows
          }
        } catch (const std::exception& e) {
          ba_errors.fetch_add(1);
          spdlog::error("{}: {}", describe(Event::kBackendError), e.what());  // not a real-time thread
        }
        continue;
      }
      if (stop_flag.load(std::memory_order_relaxed)) break;
      if (rio_done.load(std::memory_order_acquire) && keyframes->depth() == 0) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }

  // ---- publisher thread ------------------------------------------------------------------------
  void log_events(SpscQueue<Event>& q) {
    Event e;
    while (q.try_pop(e)) {
      const std::string_view what = describe(e.code);
      switch (e.code) {
        case Event::kRadarError:
        case Event::kRecordingDamage:
        case Event::kProcessingError:
          spdlog::error("{} ({}): {}", what, e.value, e.text.data());
          break;
        case Event::kRadarStale:
        case Event::kImuStale:
        case Event::kConfigMismatch:
          spdlog::warn("{}", what);
          break;
        case Event::kFrameDamaged:
        case Event::kFrameDropped:
        case Event::kDecodeError:
          spdlog::debug("{}: frame {}", what, e.value);
          break;
        default:
          spdlog::info("{}", what);
      }
    }
  }

  rsrio_msgs::msg::Status make_status() {
    rsrio_msgs::msg::Status st;
    const std::int64_t now = wall_ns();
    st.header().stamp().sec(static_cast<std::int32_t>(now / 1000000000));
    st.header().stamp().nanosec(static_cast<std::uint32_t>(now % 1000000000));
    const PipelineSnapshot snap = snapshot_now();
    st.radar_state(snap.radar_state);
    st.imu_state(snap.imu_state);
    st.frames_received(frames_received.load());
    st.frames_damaged(frames_damaged.load());
    st.frames_dropped(frames_dropped.load() + poses.dropped());
    st.packets_lost(packets_lost.load());
    auto queue = [](const char* name, const auto& q) {
      rsrio_msgs::msg::QueueStatus s;
      s.name(name);
      s.depth(static_cast<std::uint32_t>(q.size()));
      s.capacity(static_cast<std::uint32_t>(q.capacity()));
      s.pushed(q.pushed());
      s.dropped(q.dropped());
      return s;
    };
    st.queues().push_back(queue("frames", frames));
    st.queues().push_back(queue("imu", imu));
    st.queues().push_back(queue("poses", poses));
    st.queues().push_back(queue("capture_events", capture_events));
    st.queues().push_back(queue("rio_events", rio_events));
    if (keyframes) {
      rsrio_msgs::msg::QueueStatus k;
      k.name("keyframes");
      k.depth(static_cast<std::uint32_t>(keyframes->depth()));
      k.capacity(static_cast<std::uint32_t>(keyframes->capacity()));
      k.pushed(keyframes->pushed());
      k.dropped(keyframes->dropped());
      st.queues().push_back(k);
      st.ba_time_ms(static_cast<float>(ba_last_ms.load()));
      st.keyframes(static_cast<std::uint32_t>(ba_keyframes.load()));
      st.gaussians(static_cast<std::uint32_t>(ba_gaussians.load()));
    }
    st.latency_p50_ms(static_cast<float>(percentile(latencies_ms, 0.5)));
    st.latency_p99_ms(static_cast<float>(percentile(latencies_ms, 0.99)));
    std::string health;
    if (snap.radar_state != "streaming" && snap.radar_state != "finished") health += "radar " + snap.radar_state + "; ";
    // Frames arriving but damaged (packet loss) are as bad as no frames: say so.
    const std::uint64_t received = frames_received.load(), damaged = frames_damaged.load();
    const std::uint64_t new_frames = received - status_received, new_damaged = damaged - status_damaged;
    status_received = received;
    status_damaged = damaged;
    if (new_frames > 0 && 2 * new_damaged > new_frames)
      health += std::to_string(new_damaged) + " of " + std::to_string(new_frames) +
                " frames damaged since the last status (packet loss); ";
    if (snap.imu_state != "ok") health += "imu " + snap.imu_state + "; ";
    if (processing_errors.load()) health += std::to_string(processing_errors.load()) + " processing errors; ";
    if (ba_errors.load()) health += std::to_string(ba_errors.load()) + " bundle-adjustment errors; ";
    st.level(health.empty() ? 0 : (snap.radar_state.rfind("error", 0) == 0 ? 2 : 1));
    st.health(health.empty() ? "ok" : health.substr(0, health.size() - 2));
    return st;
  }

  void publisher_loop() {
    PoseOutput p;
    splat::OdomCorrection correction;  // identity until the backend's first keyframe (map = odom there)
    auto next_status = Clock::now();
    bool imu_stale_reported = false;
    while (true) {
      bool any = false;
      while (corrections.try_pop(correction)) {
      }
      while (poses.try_pop(p)) {
        any = true;
        if (backend) {
          Eigen::Isometry3d odom_T_base = Eigen::Isometry3d::Identity();
          odom_T_base.translation() = Eigen::Vector3d(p.position[0], p.position[1], p.position[2]);
          odom_T_base.linear() =
              Eigen::Quaterniond(p.orientation[3], p.orientation[0], p.orientation[1], p.orientation[2])
                  .toRotationMatrix();
          const Eigen::Isometry3d map_T_base = correction.apply(odom_T_base);  // base_link = the frontend's body
          const Eigen::Quaterniond q(map_T_base.linear());
          p.has_map_pose = true;
          p.map_position = {map_T_base.translation().x(), map_T_base.translation().y(), map_T_base.translation().z()};
          p.map_orientation = {q.x(), q.y(), q.z(), q.w()};
        }
        publisher->publish(p);
        if (latencies_ms.size() < latencies_ms.capacity()) {
          latencies_ms.push_back(1e-6 * static_cast<double>(monotonic_ns() - p.frame_complete_mono_ns));
          pickup_ms.push_back(1e-6 * static_cast<double>(p.rio_pickup_mono_ns - p.frame_complete_mono_ns));
          busy_ms.push_back(1e-6 * static_cast<double>(p.rio_end_mono_ns - p.rio_start_mono_ns));
        }
        if (pose_callback) pose_callback(p);
      }
      log_events(capture_events);
      log_events(rio_events);
      const bool imu_stale = imu_state_now() == "stale";
      if (imu_stale != imu_stale_reported) {
        spdlog::warn("{}", describe(imu_stale ? Event::kImuStale : Event::kImuBack));
        imu_stale_reported = imu_stale;
      }
      if (Clock::now() >= next_status) {
        publisher->publish(make_status());
        next_status += std::chrono::nanoseconds(static_cast<std::int64_t>(options.status_period_s * 1e9));
      }
      if (rio_done.load(std::memory_order_acquire) && poses.size() == 0) break;
      if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    publisher->publish(make_status());
    log_events(capture_events);
    log_events(rio_events);
    publisher_done.store(true);
  }

  std::string imu_state_now() const {
    const std::int64_t last = last_imu_mono_ns.load(std::memory_order_relaxed);
    if (last == 0) return "waiting";
    if (source_finished.load()) return "ok";
    return monotonic_ns() - last > static_cast<std::int64_t>(options.imu_timeout_s * 1e9) ? "stale" : "ok";
  }

  PipelineSnapshot snapshot_now() const {
    PipelineSnapshot s;
    static constexpr const char* kStates[] = {"waiting", "streaming", "stale", "error", "finished"};
    s.radar_state = kStates[radar_state.load(std::memory_order_relaxed)];
    s.imu_state = imu_state_now();
    s.streaming = streaming.load();
    s.source_finished = source_finished.load();
    s.drained = publisher_done.load();
    s.rio_heartbeat = heartbeat.load(std::memory_order_relaxed);
    return s;
  }
};

Pipeline::Pipeline(const DaemonOptions& options, const RadarConfig& radar, const rio::OdometryOptions& stage,
                   const splat::BackendOptions& backend, DdsParticipant& dds)
    : impl_(std::make_unique<Impl>(options, radar, daemon_stage(stage), backend, dds)) {
  impl_->publisher = std::make_unique<OdometryPublisher>(dds, impl_->publisher_options);
  if (options.imu_source == "dds")
    impl_->imu_reader = dds.make_reader(ros_topic_to_dds(options.imu_topic),
                                        fdds::TypeSupport(new sensor_msgs::msg::ImuPubSubType()),
                                        QosPreset::kSensorData, impl_.get());
  if (options.radar_source.rfind("recording:", 0) == 0)  // fail now, not in a thread, on a bad path
    RecordingReader probe(options.radar_source.substr(std::strlen("recording:")));
}

Pipeline::~Pipeline() {
  request_stop();
  stop();
  // The IMU reader's listener is impl_, which goes with this; the participant stays (its owner's).
  // Fast DDS calls on_data_available from its own threads until the reader is deleted: a sample
  // arriving during shutdown would otherwise lock a mutex being destroyed (the thread sanitizer's
  // run of the fault test, 2026-12-06).
  try {
    impl_->dds.delete_reader(impl_->imu_reader);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
  }
  impl_->imu_reader = nullptr;
}

void Pipeline::on_pose(std::function<void(const PoseOutput&)> callback) { impl_->pose_callback = std::move(callback); }

void Pipeline::start() {
  Impl& m = *impl_;
  const std::size_t stack = static_cast<std::size_t>(m.options.thread_stack_kib) * 1024;
  ThreadOptions pub{"rsrio-publish", 0, {}, stack};
  ThreadOptions rio{"rsrio-rio", m.options.rio_priority, m.options.rio_cpus, stack};
  ThreadOptions cap{"rsrio-capture", m.options.capture_priority, m.options.capture_cpus, stack};
  m.publisher_thread.start(pub, [&m] { m.publisher_loop(); });
  if (m.backend) {
    ThreadOptions ba{"rsrio-ba", 0, m.options.ba_cpus, stack};
    ba.nice = m.options.ba_nice;
    const ThreadPlacement bp = m.ba_thread.start(ba, [&m] { m.ba_loop(); });
    if (!bp.note.empty()) spdlog::warn("{}", bp.note);
  }
  const ThreadPlacement rp = m.rio_thread.start(rio, [&m] { m.rio_loop(); });
  const bool recording = m.options.radar_source.rfind("recording:", 0) == 0;
  const ThreadPlacement cp = m.capture_thread.start(cap, [&m, recording] {
    try {
      if (recording) m.capture_recording();
      else m.capture_dca1000();
    } catch (const std::exception& e) {
      m.radar_state.store(3);
      m.event(m.capture_events, Event::kRadarError, 0, e.what());
      m.source_finished.store(true);
    }
  });
  for (const ThreadPlacement* p : {&rp, &cp})
    if (!p->note.empty()) spdlog::warn("{}", p->note);
  if (m.options.rt_required && (m.options.rio_priority > 0 && !rp.realtime)) {
    request_stop();
    stop();
    throw std::runtime_error("rt_required is set but SCHED_FIFO was refused: " + rp.note);
  }
  if (m.options.lock_memory) {
    std::string error;
    if (!lock_memory(error)) spdlog::warn("memory not locked: {}", error);
  }
}

void Pipeline::request_stop() { impl_->stop_flag.store(true); }

bool Pipeline::stop() {
  Impl& m = *impl_;
  const auto start = Clock::now();
  m.capture_thread.join();
  m.rio_thread.join();
  m.ba_thread.join();
  m.publisher_thread.join();
  const double took = std::chrono::duration<double>(Clock::now() - start).count();
  return took <= m.options.shutdown_timeout_s;
}

PipelineSnapshot Pipeline::snapshot() const { return impl_->snapshot_now(); }

PipelineTimings Pipeline::timings() const {
  auto summary = [](const std::vector<double>& v) {
    TimingSummary s;
    s.samples = v.size();
    if (v.empty()) return s;
    s.p50 = percentile(v, 0.5);
    s.p99 = percentile(v, 0.99);
    s.max = *std::max_element(v.begin(), v.end());
    s.mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    return s;
  };
  const Impl& m = *impl_;
  return {summary(m.latencies_ms), summary(m.pickup_ms), summary(m.busy_ms), summary(m.ba_ms)};
}

}  // namespace rsrio
