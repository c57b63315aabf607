// rsrio-record: live recording from a DCA1000EVM. Drives the capture driver (connect, configure,
// start, receive), writes every frame as rsrio_msgs/RadarFrame (radar configuration, damage flags,
// zero-filled bytes counted) to a rosbag2 MCAP recording, and the IMU from a DDS
// sensor_msgs/Imu topic when one is given. SIGINT / SIGTERM (or --duration) stop the board and
// close the file completely (summary and footer), so what was recorded stays readable.
//
// Threads: the receive thread (main) polls the driver and copies each finished frame into a
// preallocated pool, handing indexes to the writer thread through SPSC queues: no allocation,
// lock, log line or file I/O on it. The writer thread serialises, writes and prints progress;
// Fast DDS's listener thread hands IMU samples over through a third queue.
// Exit 0 after a clean stop, 2 for a bad command line or configuration, 1 when the board does
// not answer or the recording cannot be written.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "cli_numbers.hpp"
#include "rsrio/common/cli.hpp"
#include "rsrio/common/log.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/common/spsc_queue.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/driver/dca1000_driver.hpp"
#include "rsrio/recording/recording.hpp"
#include "rsrio/runtime/dds.hpp"
#include "sensor_msgs/msg/ImuPubSubTypes.hpp"

namespace {

constexpr const char* kProgram = "rsrio-record";
constexpr const char* kSourceScheme = "dca1000://";

std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
extern "C" void on_signal(int) { g_stop.store(true); }

// The `dca1000` section of --config.
struct CaptureOptions {
  std::string host;  // this host's address on the board's network; "" = 127.0.0.1 for a loopback board, else TI's 192.168.33.30
  int receive_buffer_bytes = 16 << 20;
  int command_timeout_ms = 1000;
  int command_retries = 3;
  int stale_frame_ms = 250;
  int queue_frames = 16;  // frames between the receive and the writer thread
};

struct RecordOptions {
  rsrio::RadarConfig radar = rsrio::radar_preset("xwr1843");
  CaptureOptions capture;
};

void read_options(rsrio::OptionsNode& root, RecordOptions& o) {
  if (root.has("radar")) {
    rsrio::OptionsNode radar = root.child("radar");
    o.radar = rsrio::load_radar_config(radar);
  }
  rsrio::OptionsNode d = root.child("dca1000");
  d.read("host", o.capture.host);
  d.read("receive_buffer_bytes", o.capture.receive_buffer_bytes, {65536, 1 << 30});
  d.read("command_timeout_ms", o.capture.command_timeout_ms, {10, 60000});
  d.read("command_retries", o.capture.command_retries, {0, 100});
  d.read("stale_frame_ms", o.capture.stale_frame_ms, {10, 60000});
  d.read("queue_frames", o.capture.queue_frames, {2, 1024});
}

// A frame copied out of the driver's pool, waiting for the writer.
struct PooledFrame {
  std::vector<std::uint8_t> bytes;
  std::uint64_t frame_number = 0;
  std::uint32_t flags = 0;
  std::uint32_t lost_bytes = 0;
  std::int64_t completed_ns = 0;
};

// What the receive thread publishes for the progress line (relaxed: figures, not synchronisation).
struct LiveCounters {
  std::atomic<std::uint64_t> frames{0}, damaged{0}, payload_bytes{0}, packets{0}, lost_packets{0},
      kernel_drops{0}, recorder_drops{0};
};

std::int64_t realtime_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct ReceivedImu {
  sensor_msgs::msg::Imu msg;
  std::int64_t received_ns = 0;  // CLOCK_REALTIME on arrival: the log time
};

// Fast DDS's listener thread -> the writer thread.
class ImuListener : public eprosima::fastdds::dds::DataReaderListener {
 public:
  explicit ImuListener(rsrio::SpscQueue<ReceivedImu>& queue) : queue_(queue) {}
  void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
    eprosima::fastdds::dds::SampleInfo info;
    while (reader->take_next_sample(&sample_.msg, &info) == eprosima::fastdds::dds::RETCODE_OK) {
      sample_.received_ns = realtime_ns();
      if (info.valid_data) queue_.try_push(sample_);  // a full queue drops (counted by the queue)
    }
  }

 private:
  rsrio::SpscQueue<ReceivedImu>& queue_;
  ReceivedImu sample_;
};

void set_stamp(builtin_interfaces::msg::Time& stamp, std::int64_t ns) {
  stamp.sec(static_cast<std::int32_t>(ns / 1'000'000'000));
  stamp.nanosec(static_cast<std::uint32_t>(ns % 1'000'000'000));
}

}  // namespace

int main(int argc, char** argv) {
  std::string source, out_path, duration_text, imu_topic;
  bool rosbag2 = false;
  rsrio::Cli cli(kProgram,
                 "Record a DCA1000EVM live into an MCAP recording: raw radar frames (/radar/raw, with the radar\n"
                 "configuration and per-frame damage flags) and, with --imu-topic, the IMU (/imu) from DDS.");
  cli.option("--source", "dca1000://ADDR", "the board, e.g. dca1000://192.168.33.180 or dca1000://127.0.0.2:4096 "
             "(required)", &source);
  cli.option("--out", "REC.mcap", "the recording to write (required; replaced if it exists)", &out_path);
  cli.option("--duration", "S", "stop after S seconds of streaming (default: until SIGINT / SIGTERM)",
             &duration_text);
  cli.option("--imu-topic", "TOPIC", "also record sensor_msgs/Imu from this DDS topic (e.g. rt/imu)", &imu_topic);
  cli.flag("--rosbag2",
           "also write metadata.yaml beside the recording: its directory becomes a rosbag2 bag (for\n"
           "      python3-rosbags; name the file DIR/NAME_0.mcap)",
           &rosbag2);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  RecordOptions options;
  if (auto rc = rsrio::load_program_config(cli, kProgram, [&](rsrio::OptionsNode& root) { read_options(root, options); }))
    return *rc;

  if (source.rfind(kSourceScheme, 0) != 0)
    return cli.usage_error("--source: expected dca1000://ADDR[:PORT], got '" + source + "'");
  if (out_path.empty()) return cli.usage_error("--out REC.mcap is required");
  double duration = 0;
  if (!duration_text.empty() && (!rsrio::tools::parse_double(duration_text, duration) || duration <= 0))
    return cli.usage_error("--duration: expected a positive number of seconds, got '" + duration_text + "'");
  if (options.radar.capture.format != "dca1000")
    return cli.usage_error("radar preset '" + options.radar.preset + "' is captured as '" + options.radar.capture.format +
                           "', not through a DCA1000");
  rsrio::Dca1000Options driver_options;
  try {
    driver_options.board = rsrio::Endpoint::parse(source.substr(std::strlen(kSourceScheme)), rsrio::dca1000::kConfigPort);
    const bool loopback = (driver_options.board.ip >> 24) == 127;
    const std::string host = !options.capture.host.empty() ? options.capture.host : loopback ? "127.0.0.1" : "192.168.33.30";
    driver_options.host_config = rsrio::Endpoint::parse(host, rsrio::dca1000::kConfigPort);
    driver_options.host_data = {driver_options.host_config.ip, rsrio::dca1000::kDataPort};
  } catch (const std::invalid_argument& e) {
    return cli.usage_error(std::string("--source / dca1000.host: ") + e.what());
  }
  driver_options.receive_buffer_bytes = options.capture.receive_buffer_bytes;
  driver_options.command_timeout = std::chrono::milliseconds(options.capture.command_timeout_ms);
  driver_options.command_retries = options.capture.command_retries;
  driver_options.stale_frame = std::chrono::milliseconds(options.capture.stale_frame_ms);
  const std::size_t frame_bytes = rsrio::dca1000_frame_bytes(options.radar);

  std::cerr << kProgram << ": radar configuration:\n";
  rsrio::print(std::cerr, options.radar);
  spdlog::info("{}: board {}, host {} (data port {}), frames of {} bytes every {} ms -> {}", kProgram,
               driver_options.board.to_string(), driver_options.host_config.ip_string(), driver_options.host_data.port,
               frame_bytes, options.radar.frame_period_ms, out_path);
  spdlog::info("dca1000: receive_buffer_bytes {}, command_timeout_ms {}, command_retries {}, stale_frame_ms {}, "
               "queue_frames {}",
               options.capture.receive_buffer_bytes, options.capture.command_timeout_ms,
               options.capture.command_retries, options.capture.stale_frame_ms, options.capture.queue_frames);

  std::unique_ptr<rsrio::Dca1000Driver> driver;
  std::unique_ptr<rsrio::RecordingWriter> writer;
  try {
    driver = std::make_unique<rsrio::Dca1000Driver>(driver_options, frame_bytes);
    rsrio::RecordingWriterOptions writer_options;
    writer_options.write_rosbag2_metadata = rosbag2;
    if (const auto parent = std::filesystem::path(out_path).parent_path(); !parent.empty())
      std::filesystem::create_directories(parent);
    writer = std::make_unique<rsrio::RecordingWriter>(out_path, writer_options);
  } catch (const std::exception& e) {
    std::cerr << kProgram << ": error: " << e.what() << "\n";
    return 1;
  }
  if (driver->data_socket().receive_buffer_bytes() < driver_options.receive_buffer_bytes)
    spdlog::warn("socket receive buffer is {} bytes, {} asked: raise net.core.rmem_max, or frames may be lost in bursts",
                 driver->data_socket().receive_buffer_bytes(), driver_options.receive_buffer_bytes);

  // IMU over DDS (optional).
  const std::size_t queue_frames = static_cast<std::size_t>(options.capture.queue_frames);
  rsrio::SpscQueue<ReceivedImu> imu_queue(4096);
  ImuListener imu_listener(imu_queue);
  std::unique_ptr<rsrio::DdsParticipant> dds;
  if (!imu_topic.empty()) {
    const std::string dds_topic = imu_topic.rfind("rt/", 0) == 0 ? imu_topic : rsrio::ros_topic_to_dds(imu_topic);
    try {
      rsrio::DdsOptions dds_options;
      dds_options.participant_name = kProgram;
      if (const char* d = std::getenv("ROS_DOMAIN_ID")) dds_options.domain_id = std::atoi(d);
      dds = std::make_unique<rsrio::DdsParticipant>(dds_options);
      dds->make_reader(dds_topic, eprosima::fastdds::dds::TypeSupport(new sensor_msgs::msg::ImuPubSubType()),
                       rsrio::QosPreset::kSensorData, &imu_listener);
    } catch (const std::exception& e) {
      std::cerr << kProgram << ": error: IMU topic " << dds_topic << ": " << e.what() << "\n";
      return 1;
    }
    spdlog::info("recording sensor_msgs/Imu from DDS topic {}", dds_topic);
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    const auto version = driver->start();
    spdlog::info("DCA1000 FPGA {}.{}{}: streaming", version.major, version.minor,
                 version.playback ? " (playback mode)" : "");
  } catch (const rsrio::Dca1000Error& e) {
    std::cerr << kProgram << ": error: " << e.what() << "\n";
    writer->close();
    return 1;
  }
  const auto started = std::chrono::steady_clock::now();

  // The frame pool: allocated here, once.
  std::vector<PooledFrame> pool(queue_frames);
  for (auto& p : pool) p.bytes.resize(frame_bytes);
  rsrio::SpscQueue<std::uint32_t> full(queue_frames), free_frames(queue_frames);
  for (std::uint32_t i = 0; i < queue_frames; ++i) free_frames.try_push(i);
  LiveCounters live;
  std::atomic<bool> receiving_done{false}, writer_failed{false};
  std::string writer_error;
  std::uint64_t frames_written = 0, damaged_written = 0, imu_written = 0;
  const std::int64_t realtime_offset = driver->realtime_offset_ns();

  std::thread writer_thread([&] {
    rsrio_msgs::msg::RadarFrame msg;
    msg.header().frame_id("radar");
    msg.config(rsrio::to_msg(options.radar));
    msg.adc().reserve(frame_bytes);
    const bool tty = isatty(STDERR_FILENO) != 0;
    auto last_report = std::chrono::steady_clock::now();
    std::uint64_t last_bytes = 0;
    auto report = [&](bool final_line) {
      const auto now = std::chrono::steady_clock::now();
      const double dt = std::chrono::duration<double>(now - last_report).count();
      const std::uint64_t bytes = live.payload_bytes.load(std::memory_order_relaxed);
      const std::uint64_t packets = live.packets.load(std::memory_order_relaxed);
      const std::uint64_t lost = live.lost_packets.load(std::memory_order_relaxed);
      const double rate = dt > 0 ? (bytes - last_bytes) / dt / 1e6 : 0.0;
      std::fprintf(stderr, "%sframes %llu (damaged %llu) | %.2f MB/s | loss %.2f %% | kernel drops %llu%s",
                   tty ? "\r" : "", static_cast<unsigned long long>(live.frames.load(std::memory_order_relaxed)),
                   static_cast<unsigned long long>(live.damaged.load(std::memory_order_relaxed)), rate,
                   packets + lost ? 100.0 * double(lost) / double(packets + lost) : 0.0,
                   static_cast<unsigned long long>(live.kernel_drops.load(std::memory_order_relaxed)),
                   tty && !final_line ? "   " : "\n");
      last_report = now;
      last_bytes = bytes;
    };
    try {
      while (true) {
        bool idle = true;
        std::uint32_t i = 0;
        if (full.try_pop(i)) {
          idle = false;
          const PooledFrame& f = pool[i];
          const std::int64_t stamp = f.completed_ns + realtime_offset;
          set_stamp(msg.header().stamp(), stamp);
          msg.frame_number(f.frame_number);
          msg.monotonic_ns(static_cast<std::uint64_t>(f.completed_ns));
          msg.flags(f.flags);
          msg.lost_bytes(f.lost_bytes);
          msg.adc().assign(f.bytes.begin(), f.bytes.end());  // capacity reserved: no allocation
          free_frames.try_push(i);
          writer->write(rsrio::topics::kRadarRaw, msg, static_cast<std::uint64_t>(stamp));
          ++frames_written;
          if (f.flags & rsrio::kFrameDamaged) ++damaged_written;
        }
        ReceivedImu imu;
        while (imu_queue.try_pop(imu)) {
          idle = false;
          writer->write(rsrio::topics::kImu, imu.msg, static_cast<std::uint64_t>(imu.received_ns));
          ++imu_written;
        }
        if (std::chrono::steady_clock::now() - last_report >= std::chrono::seconds(1)) report(false);
        if (idle) {
          if (receiving_done.load(std::memory_order_acquire) && full.size() == 0) break;
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
      }
      report(true);
    } catch (const std::exception& e) {
      writer_error = e.what();
      writer_failed.store(true);
      g_stop.store(true);
    }
  });

  // The receive loop (real-time discipline: no allocation, locks, logging or I/O but the socket).
  auto hand_over = [&](rsrio::AssembledFrame* f, bool may_wait) {
    std::uint32_t i = 0;
    bool got = free_frames.try_pop(i);
    // At the end nothing is streaming any more: waiting for the writer loses nothing.
    while (!got && may_wait && !writer_failed.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      got = free_frames.try_pop(i);
    }
    if (got) {
      PooledFrame& p = pool[i];
      std::memcpy(p.bytes.data(), f->bytes.data(), frame_bytes);
      p.frame_number = f->frame_number;
      p.flags = f->flags;
      p.lost_bytes = f->lost_bytes;
      p.completed_ns = f->completed_ns;
      full.try_push(i);
      live.frames.fetch_add(1, std::memory_order_relaxed);
      if (f->flags & rsrio::kFrameDamaged) live.damaged.fetch_add(1, std::memory_order_relaxed);
    } else {
      live.recorder_drops.fetch_add(1, std::memory_order_relaxed);  // the disk cannot keep up
    }
    driver->release(f);
  };
  auto publish = [&] {
    const auto& a = driver->assembler_counters();
    live.payload_bytes.store(a.payload_bytes, std::memory_order_relaxed);
    live.packets.store(a.packets, std::memory_order_relaxed);
    live.lost_packets.store(a.lost_packets, std::memory_order_relaxed);
    live.kernel_drops.store(driver->counters().kernel_drops, std::memory_order_relaxed);
  };
  const auto deadline = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(duration > 0 ? duration : 1e9));
  while (!g_stop.load() && std::chrono::steady_clock::now() < deadline) {
    driver->poll(std::chrono::milliseconds(20));
    while (rsrio::AssembledFrame* f = driver->next_frame()) hand_over(f, false);
    driver->poll_config();
    publish();
  }
  driver->stop();  // STOP_RECORD, then the open frames are closed (flagged if incomplete)
  while (rsrio::AssembledFrame* f = driver->next_frame()) hand_over(f, true);
  publish();
  receiving_done.store(true, std::memory_order_release);
  writer_thread.join();
  dds.reset();  // no more IMU callbacks

  int rc = 0;
  try {
    writer->close();
  } catch (const std::exception& e) {
    writer_error = e.what();
    writer_failed.store(true);
  }
  if (writer_failed.load()) {
    std::cerr << kProgram << ": error: " << writer_error << "\n";
    rc = 1;
  }
  const auto& a = driver->assembler_counters();
  const auto& d = driver->counters();
  std::printf(
      "%s: wrote frames=%llu damaged=%llu imu=%llu; lost_packets=%llu out_of_order=%llu duplicates=%llu "
      "zero_filled_bytes=%llu frames_skipped=%llu kernel_drops=%llu recorder_drops=%llu imu_drops=%llu foreign=%llu -> %s\n",
      kProgram, static_cast<unsigned long long>(frames_written), static_cast<unsigned long long>(damaged_written),
      static_cast<unsigned long long>(imu_written), static_cast<unsigned long long>(a.lost_packets),
      static_cast<unsigned long long>(a.out_of_order_packets), static_cast<unsigned long long>(a.duplicate_packets),
      static_cast<unsigned long long>(a.zero_filled_bytes), static_cast<unsigned long long>(a.frames_skipped),
      static_cast<unsigned long long>(d.kernel_drops), static_cast<unsigned long long>(live.recorder_drops.load()),
      static_cast<unsigned long long>(imu_queue.dropped()),
      static_cast<unsigned long long>(d.foreign_datagrams), out_path.c_str());
  std::fflush(stdout);
  return rc;
}
