// rsriod: the radar-inertial odometry daemon. Radar from a DCA1000 (or its emulator) or from a
// recording, IMU from DDS or the recording; poses out over DDS (nav_msgs/Odometry,
// geometry_msgs/PoseStamped) and a status once a second. Under systemd: READY=1 once the radar
// streams and DDS is up, WATCHDOG=1 only while the RIO loop makes progress.
//
// Exit codes: 0 after SIGINT/SIGTERM or the end of a recording, 1 on a runtime failure,
// 2 on a bad command line or configuration.
#include <csignal>
#include <ctime>
#include <iostream>

#include <spdlog/spdlog.h>

#include "rsrio/common/cli.hpp"
#include "rsrio/common/log.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/recording/recording.hpp"
#include "rsrio/runtime/dds.hpp"
#include "rsrio/runtime/estimator_options.hpp"
#include "rsrio/runtime/pipeline.hpp"
#include "rsrio/runtime/systemd_notify.hpp"
#include "rsrio/splat/backend.hpp"

namespace {

// The radar configuration a recording was made with (its first frame carries it).
std::optional<rsrio::RadarConfig> recording_radar(const std::string& path) {
  rsrio::RecordingReader reader(path);
  rsrio::RecordedMessage m;
  rsrio_msgs::msg::RadarFrame frame;
  while (reader.next(m))
    if (m.schema_name == "rsrio_msgs/msg/RadarFrame" && rsrio::decode(m, frame)) return rsrio::from_msg(frame.config());
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  std::string source, imu_source, domain, backend_name;
  bool progress = false;
  rsrio::Cli cli("rsriod", "Radar-inertial odometry daemon: TI mmWave radar + IMU -> poses over DDS.");
  cli.option("--source", "URI", "radar source: dca1000://BOARD[:HOST] or recording:PATH (overrides daemon.radar_source)",
             &source)
      .option("--imu-source", "dds|recording", "where IMU comes from (overrides daemon.imu_source)", &imu_source)
      .option("--domain", "ID", "DDS domain (overrides daemon.domain_id)", &domain)
      .option("--backend", "none|ba", "backend after the frontend (overrides daemon.backend)", &backend_name)
      .flag("--progress", "print a progress line every second", &progress);
  if (auto rc = cli.parse(argc, argv)) return *rc;

  rsrio::DaemonOptions daemon;
  rsrio::RadarConfig radar = rsrio::radar_preset("xwr1843");
  bool radar_given = false;
  rsrio::EstimatorOptions estimator;
  if (auto rc = rsrio::load_program_config(cli, "rsriod", [&](rsrio::OptionsNode& root) {
        if (root.has("daemon")) {
          rsrio::OptionsNode n = root.child("daemon");
          daemon = rsrio::load_daemon_options(n);
        }
        if (root.has("radar")) {
          rsrio::OptionsNode n = root.child("radar");
          radar = rsrio::load_radar_config(n);
          radar_given = true;
        }
        estimator = rsrio::load_estimator_options(root);
        // A batch over the whole run keeps every factor: a daemon's memory would grow without bound.
        if (estimator.odometry.frontend.whole_run_smoother)
          throw rsrio::ConfigError(root.file(), "frontend.whole_run_smoother",
                                   "false in rsriod (the whole run as one batch is rsrio-replay's end of run)");
      }))
    return *rc;
  rsrio::rio::OdometryOptions& stage = estimator.odometry;
  rsrio::splat::BackendOptions& backend = estimator.backend;
  if (!source.empty()) daemon.radar_source = source;
  if (!imu_source.empty()) daemon.imu_source = imu_source;
  try {
    if (!domain.empty()) daemon.domain_id = std::stoi(domain);
  } catch (const std::exception&) {
    return cli.usage_error("--domain: expected an integer, got '" + domain + "'");
  }
  if (daemon.radar_source.rfind("dca1000://", 0) != 0 && daemon.radar_source.rfind("recording:", 0) != 0)
    return cli.usage_error("--source: expected dca1000://BOARD[:HOST] or recording:PATH, got '" + daemon.radar_source +
                           "'");
  if (!backend_name.empty()) daemon.backend = backend_name;
  if (daemon.backend != "none" && daemon.backend != "ba")
    return cli.usage_error("--backend: expected none or ba, got '" + daemon.backend + "'");
  if (daemon.imu_source != "dds" && daemon.imu_source != "recording")
    return cli.usage_error("--imu-source: expected dds or recording");

  // Signals are taken synchronously by the main thread; every thread made later inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  try {
    if (daemon.radar_source.rfind("recording:", 0) == 0) {
      const std::string path = daemon.radar_source.substr(std::strlen("recording:"));
      auto rec = recording_radar(path);
      if (!rec) {
        std::cerr << "rsriod: error: " << path << ": no radar frame in the recording\n";
        return 1;
      }
      if (radar_given) spdlog::warn("the recording carries its radar configuration; the radar: section is ignored");
      radar = *rec;
    }
    std::cout << "# rsriod " << rsrio::version_string() << "\n";
    rsrio::print(std::cout, daemon);
    rsrio::print(std::cout, radar);
    rsrio::rio::print(std::cout, stage);
    rsrio::splat::take_frontend_options(backend, stage);  // extrinsic and point spread from the frontend
    if (daemon.backend == "ba") rsrio::splat::print(std::cout, backend);
    std::cout.flush();

    // DDS before any real-time thread: its own threads must not inherit SCHED_FIFO.
    rsrio::DdsOptions dds_options;
    dds_options.domain_id = daemon.domain_id;
    dds_options.loopback_only = daemon.loopback_only;
    dds_options.participant_name = "rsriod";
    rsrio::DdsParticipant dds(dds_options);
    rsrio::Pipeline pipeline(daemon, radar, stage, backend, dds);
    std::atomic<std::uint64_t> poses{0};
    std::atomic<std::int64_t> last_stamp_ns{0};
    pipeline.on_pose([&](const rsrio::PoseOutput& p) {
      poses.fetch_add(1, std::memory_order_relaxed);
      last_stamp_ns.store(p.stamp_ns, std::memory_order_relaxed);
    });
    pipeline.start();
    spdlog::info("started: radar {}, IMU {}, poses on {} and {}", daemon.radar_source, daemon.imu_source,
                 daemon.odom_topic, daemon.pose_topic);

    const auto watchdog = rsrio::systemd::watchdog_interval();
    bool ready = false;
    std::uint64_t last_heartbeat = 0;
    auto last_ping = std::chrono::steady_clock::now();
    auto last_progress = last_ping;
    int stop_signal = 0;
    while (true) {
      timespec wait{0, 100 * 1000 * 1000};
      const int sig = sigtimedwait(&signals, nullptr, &wait);
      if (sig == SIGINT || sig == SIGTERM) {
        stop_signal = sig;
        break;
      }
      const rsrio::PipelineSnapshot s = pipeline.snapshot();
      if (!ready && s.streaming) {
        rsrio::systemd::ready();
        ready = true;
        spdlog::info("ready: radar streaming, DDS up");
      }
      const auto now = std::chrono::steady_clock::now();
      // The watchdog is fed only when the RIO loop went round since the last ping.
      if (watchdog.count() > 0 && now - last_ping >= watchdog / 2 && s.rio_heartbeat != last_heartbeat) {
        rsrio::systemd::watchdog();
        last_heartbeat = s.rio_heartbeat;
        last_ping = now;
      }
      if (progress && now - last_progress >= std::chrono::seconds(1)) {
        std::cerr << "\rrsriod: radar " << s.radar_state << ", imu " << s.imu_state << ", poses " << poses.load()
                  << "        " << std::flush;
        last_progress = now;
      }
      if (s.drained) break;
    }
    if (progress) std::cerr << "\n";
    rsrio::systemd::stopping();
    if (stop_signal) spdlog::info("{}: stopping", stop_signal == SIGINT ? "SIGINT" : "SIGTERM");
    pipeline.request_stop();
    if (!pipeline.stop()) spdlog::warn("shutdown took longer than {} s", daemon.shutdown_timeout_s);
    const rsrio::PipelineTimings tm = pipeline.timings();
    auto line = [](const char* what, const rsrio::TimingSummary& s) {
      if (s.samples > 0)
        spdlog::info("{}: p50 {:.2f} ms, p99 {:.2f} ms, max {:.2f} ms, mean {:.2f} ms over {}", what, s.p50, s.p99,
                     s.max, s.mean, s.samples);
    };
    line("latency frame complete -> odometry published", tm.latency);
    line("RIO pickup (frame complete -> RIO thread)", tm.rio_pickup);
    line("RIO processing per frame", tm.rio_busy);
    line("bundle adjustment per keyframe", tm.ba);
    const std::int64_t last = last_stamp_ns.load();
    spdlog::info("stopped after {} poses, last pose at {}.{:09d}", poses.load(), last / 1000000000, last % 1000000000);
  } catch (...) {
    return rsrio::report_program_error("rsriod", std::current_exception());
  }
  return 0;
}
