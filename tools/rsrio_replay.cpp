// rsrio-replay: runs the odometry (DSP -> ego-velocity -> frontend [-> backend]) over a recording
// as fast as the machine allows and writes what it estimated.
//
//   rsrio-replay --input REC.mcap --out DIR [--config FILE] [--backend none|ba [--pipelined]
//                [--backend-poses frontend|constant-velocity] [--repeatable]]
//                [--odometry-drift DEG_PER_S,SCALE | --odometry-truth]
//
// --repeatable: the backend's stages without their time budgets (each runs its iterations or to
// convergence, however long that takes), so that the same recording and options give the same
// trajectory to the last digit: what the budgets stop depends on the machine and its load, and
// the backend's result with it. Sequential only; not real time.
// --backend-poses constant-velocity is the paper's `no frontend` ablation: the backend's keyframes
// start from its own constant-velocity prediction instead of the frontend's motion (the frontend
// still runs, for frontend.tum).
// --odometry-drift: every frontend pose (frontend.tum and what the backend takes) as a frontend
// with a heading drift of DEG_PER_S and a speed error of SCALE (0.01: every step 1 % long) would
// give it (OdometryDrift): how much of a drift the size of the paper's MRIO (0.9-22 m on its
// sequences; this frontend's is 0.14-0.46 m on the simulated ones) the backend takes out.
// --odometry-truth: every frontend pose (frontend.tum and what the backend takes) is the
// recording's /ground_truth at the frame's time, tilt and height included: the backend given a
// perfect frontend, its own floor (what its image losses do to poses that were right).
// DIR/frontend.tum   the frontend's radar-frame pose per radar frame (TUM, radar clock, world = the
//                    frontend's: origin at the first state, yaw 0 there)
// DIR/estimate.tum   the pose after the backend as published (causal; = frontend.tum with --backend none)
// DIR/ground_truth.tum  /ground_truth of the recording (the radar frame in the map), if present,
//                    interpolated at the stamps of frontend.tum (none across a gap of 0.25 s)
// DIR/stats.json     frames, rejections by reason, damaged frames, timings (p50/p99), peak memory
// DIR/frontend_smoothed.tum  with frontend.whole_run_smoother: every state of the run as one batch
//                    over every factor solved it at the end (not causal; in the window's frame,
//                    without the offsets by which frontend.tum carries the zero-rate updates'
//                    re-estimates forward, so the two may part by a rotation about the vertical)
// With --backend ba also
// DIR/estimate_final.tum  every frame's pose as the backend's map has it at the end of the run
//                    (Backend::revised: later BA and loop closures correct earlier poses, and the
//                    frontend's last accelerometer bias their roll and pitch; not causal); with
//                    frontend.whole_run_smoother the frontend's poses are the batch's (keyframes
//                    before the end-of-run BA, and every frame), not retilted
// and the pictures (SPEC Sec. 11):
// DIR/keyframe_NNNN_ra.png, _rd.png  measured | rendered RA and RD of a few keyframes (--pictures N)
// DIR/map.png        the Gaussian map from above with the frontend's and the backend's trajectories
//                    (as published and at the end of the run) and the ground truth, aligned to
//                    the end-of-run one by SE(3)
//
// Frames are processed once the IMU has reached their measurement time (or at the end of the
// recording), so a recording whose IMU messages lag the radar's is replayed as the daemon would see
// it with a short buffer. A recording cut short (crash, full disk) is replayed up to the damage and
// the damage is reported (stderr and stats.json), with exit code 0: what could be read is valid.
//
// Exit codes: 0 done; 1 input or output failure; 2 bad command line or configuration.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/resource.h>

#include "rsrio/common/cli.hpp"
#include "rsrio/common/log.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/eval/trajectory.hpp"
#include "rsrio/recording/recording.hpp"
#include "rsrio/runtime/estimator_options.hpp"
#include "rsrio/runtime/keyframe_handoff.hpp"
#include "rsrio/rio/odometry.hpp"
#include "cli_numbers.hpp"
#include "rsrio/eval/plot.hpp"
#include "rsrio/splat/backend.hpp"
#include "rsrio/splat/image_dump.hpp"

namespace {

constexpr const char* kProgram = "rsrio-replay";
// Interpolate the ground truth only between samples this close: the simulator's come every 5 ms,
// a motion-capture system's at 10 Hz or faster; a longer gap is a dropout, not a pose.
constexpr double kGroundTruthMaxGapS = 0.25;

double seconds(const builtin_interfaces::msg::Time& t) { return t.sec() + 1e-9 * t.nanosec(); }

rsrio::eval::StampedPose stamped(double t, const gtsam::Pose3& pose) {
  return {t, pose.translation(), pose.rotation().toQuaternion()};
}

// A /ground_truth message's pose (the radar in the map); nullopt if it does not decode.
std::optional<rsrio::eval::StampedPose> ground_truth_pose(const rsrio::RecordedMessage& m) {
  nav_msgs::msg::Odometry gt;
  if (!rsrio::decode(m, gt)) return std::nullopt;
  const auto& p = gt.pose().pose();
  return rsrio::eval::StampedPose{
      seconds(gt.header().stamp()),
      {p.position().x(), p.position().y(), p.position().z()},
      Eigen::Quaterniond(p.orientation().w(), p.orientation().x(), p.orientation().y(), p.orientation().z()).normalized()};
}

// A perfect frontend (--odometry-truth): the recording's ground truth, read before the replay
// (its messages need not come before the frames they cover), interpolated at a frame's time.
class OdometryTruth {
 public:
  explicit OdometryTruth(const std::string& input) {
    rsrio::RecordingReader reader(input);
    rsrio::RecordedMessage m;
    while (reader.next(m))
      if (m.topic == rsrio::topics::kGroundTruth)
        if (const auto pose = ground_truth_pose(m)) truth_.push_back(*pose);
    std::stable_sort(truth_.begin(), truth_.end(), [](const auto& a, const auto& b) { return a.t < b.t; });
    if (truth_.size() < 2)
      throw std::runtime_error(input + ": --odometry-truth needs the recording's " + rsrio::topics::kGroundTruth +
                               ", which has " + std::to_string(truth_.size()) + " poses");
  }
  /// The radar's pose at t; nullopt outside the truth or across one of its gaps.
  std::optional<gtsam::Pose3> world_T_radar(double t) const {
    auto b = std::lower_bound(truth_.begin(), truth_.end(), t, [](const auto& p, double time) { return p.t < time; });
    if (b == truth_.end()) return std::nullopt;
    if (b == truth_.begin()) b = std::next(b);  // t at the first sample: interpolated between the first two
    const rsrio::eval::Trajectory at = rsrio::eval::resampled({*std::prev(b), *b}, {t}, kGroundTruthMaxGapS);
    if (at.empty()) return std::nullopt;
    return gtsam::Pose3(gtsam::Rot3(at.front().q), at.front().p);
  }

 private:
  rsrio::eval::Trajectory truth_;
};

const char* status_key(rsrio::rio::EgoVelocityStatus s) {
  using S = rsrio::rio::EgoVelocityStatus;
  switch (s) {
    case S::kOk: return "ok";
    case S::kTooFewPoints: return "too_few_points";
    case S::kTooFewInliers: return "too_few_inliers";
    case S::kDegenerate: return "degenerate";
    case S::kImplausible: return "implausible";
  }
  return "unknown";
}

struct Percentiles {
  double p50 = 0, p99 = 0, max = 0, mean = 0;
};
Percentiles percentiles(std::vector<double> v) {
  Percentiles p;
  if (v.empty()) return p;
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5))]; };
  p.p50 = at(0.5);
  p.p99 = at(0.99);
  p.max = v.back();
  double s = 0;
  for (double x : v) s += x;
  p.mean = s / static_cast<double>(v.size());
  return p;
}

std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      o += ' ';
      continue;
    }
    o += c;
  }
  return o + "\"";
}

// A frontend that drifts, made from this one (--odometry-drift): a gyro bias about the vertical
// turns the heading by yaw_rate * t, a speed bias makes every step `scale` too long. Each frame's
// motion since the previous one is turned by the heading error reached by then and scaled, and
// the attitude turned about the world's vertical (the tilt stays the frontend's).
class OdometryDrift {
 public:
  OdometryDrift(double yaw_rate_rad_s, double scale) : yaw_rate_(yaw_rate_rad_s), scale_(scale) {}
  gtsam::Pose3 apply(double t, const gtsam::Pose3& world_T_body) {
    if (yaw_rate_ == 0 && scale_ == 0) return world_T_body;  // 0,0: the frontend's poses to the last bit
    if (!started_) {
      started_ = true;
      drifted_ = world_T_body;
    } else {
      yaw_ += yaw_rate_ * (t - t_);
      const gtsam::Rot3 turn = gtsam::Rot3::Yaw(yaw_);
      const gtsam::Point3 step = world_T_body.translation() - last_.translation();
      drifted_ = gtsam::Pose3(turn * world_T_body.rotation(), drifted_.translation() + (1 + scale_) * turn.rotate(step));
    }
    t_ = t;
    last_ = world_T_body;
    return drifted_;
  }

 private:
  double yaw_rate_, scale_;
  bool started_ = false;
  double t_ = 0, yaw_ = 0;
  gtsam::Pose3 last_, drifted_;
};

// The one place a backend takes each frame and returns the corrected pose. With `none` it returns
// the frontend's pose; the bundle-adjustment backend plugs in here.
class Backend {
 public:
  virtual ~Backend() = default;
  virtual gtsam::Pose3 process(const rsrio::rio::FrameInfo& frame, const rsrio::AdcCube& cube) = 0;
};
class NoBackend final : public Backend {
 public:
  gtsam::Pose3 process(const rsrio::rio::FrameInfo& frame, const rsrio::AdcCube&) override {
    return frame.world_T_radar;
  }
};

// RadarSplat++ bundle adjustment (splat/backend.hpp): made at the first frame, when the radar's
// DSP grids are known; takes every frame with a frontend state and returns the corrected radar pose.
// Sequential (default): the backend optimises each keyframe before the next frame is processed,
// on the one thread. Pipelined (--pipelined): as the daemon, the backend runs on its own thread
// and takes the keyframe candidates through the daemon's KeyframeHandoff (2 slots); a frame is
// published with the newest correction the backend has made by then, so corrections arrive a
// keyframe or two late, as they do in rsriod. Unlike the daemon it never drops a candidate: when
// both slots are taken the frontend waits for the backend (a replay has no clock to keep up with),
// so both modes optimise the same keyframes and differ only in when their corrections are used.
class BaBackend final : public Backend {
 public:
  // `alone`: the backend tracks without the frontend (the paper's `no frontend` ablation): each
  // frame's pose is the backend's own constant-velocity prediction (Backend::predicted), given as
  // odom_T_body = map_T_odom^-1 predicted, so a keyframe starts from the prediction. Sequential only.
  BaBackend(const std::optional<rsrio::rio::Odometry>& odometry, rsrio::splat::BackendOptions options, bool pipelined,
            bool alone)
      : odometry_(odometry), options_(std::move(options)), pipelined_(pipelined), alone_(alone) {}
  ~BaBackend() override {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  gtsam::Pose3 process(const rsrio::rio::FrameInfo& frame, const rsrio::AdcCube&) override {
    const auto& dsp = odometry_->dsp();
    if (!backend_) start(dsp);
    const gtsam::Pose3 odom_T_body =
        alone_ ? backend_->map_T_odom().inverse() * backend_->predicted(frame.t) : frame.state->world_T_body;
    // Alone, no frontend bias retilts the poses (final_trajectory): the same (zero) bias throughout.
    frames_.push_back({frame.t, odom_T_body, alone_ ? gtsam::Vector3::Zero() : frame.state->bias.accelerometer()});
    if (!alone_ && frame.state->settled) settle(*frame.state->settled);
    const gtsam::Pose3& body_T_radar = odometry_->options().frontend.body_T_radar;
    if (!pipelined_) {
      rsrio::splat::BackendFrame f;
      f.t = frame.t;
      f.odom_T_body = odom_T_body;
      f.dsp = &dsp.result();  // this frame's: add_radar_frame just processed it
      const auto t0 = std::chrono::steady_clock::now();
      if (backend_->add_frame(f))
        keyframe_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      return backend_->corrected(odom_T_body) * body_T_radar;
    }
    if (handoff_->free_slots() == 0) {
      const auto t0 = std::chrono::steady_clock::now();
      while (handoff_->free_slots() == 0 && !failed_.load()) std::this_thread::sleep_for(std::chrono::microseconds(200));
      waited_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    rethrow_failure();
    handoff_->offer(frame.t, Eigen::Isometry3d(frame.state->world_T_body.matrix()), dsp.result());
    rsrio::splat::OdomCorrection correction;
    {
      std::lock_guard<std::mutex> lock(correction_mutex_);
      correction = correction_;
    }
    return gtsam::Pose3(correction.apply(Eigen::Isometry3d(frame.state->world_T_body.matrix())).matrix()) * body_T_radar;
  }
  /// Pipelined: waits until the backend has optimised every candidate handed over, then stops its
  /// thread (rethrowing what it failed with). Then the backend's end-of-run BA (its final_ba
  /// options; off by default), which moves estimate_final.tum only.
  /// `smoothed` (the frontend's whole run as one batch, frontend.whole_run_smoother; empty: none)
  /// replaces the frontend's poses of the keyframes before the end-of-run BA and of every frame in
  /// final_trajectory().
  void finish(std::vector<rsrio::rio::SmoothedState> smoothed = {}) {
    if (thread_.joinable()) {
      input_done_.store(true);
      thread_.join();
      rethrow_failure();
    }
    smoothed_ = std::move(smoothed);
    if (backend_ && !smoothed_.empty()) backend_->replace_odometry([this](double t) { return smoothed_at(t); });
    if (backend_) backend_->finish();
  }
  rsrio::splat::Backend* backend() { return backend_ ? &*backend_ : nullptr; }
  /// Every frame's radar pose as the map has it now (Backend::revised), in the frames' order, with
  /// the frontend's tilt as its window last estimated it (rio::SettledState: smoothed by the
  /// frames after it; the newest window_states frames keep the tilt published) retilted with the
  /// frontend's last accelerometer bias (rio::retilted: the backend keeps the frontend's tilt,
  /// which a bias learnt in later turns corrects; 3-DoF poses exactly, 6-DoF ones within their
  /// vertical prior). Pipelined: after finish().
  rsrio::eval::Trajectory final_trajectory() const {
    rsrio::eval::Trajectory out;
    if (!backend_ || frames_.empty()) return out;
    out.reserve(frames_.size());
    const auto& frontend = odometry_->options().frontend;
    const gtsam::Vector3 last_bias = frames_.back().accel_bias;
    for (const auto& f : frames_) {
      if (const std::optional<gtsam::Pose3> smoothed = smoothed_at(f.t)) {
        out.push_back(stamped(f.t, backend_->revised(f.t, *smoothed) * frontend.body_T_radar));
        continue;
      }
      const gtsam::Pose3 odom_T_body =
          f.settled_attitude
              ? rsrio::rio::retilted(rsrio::rio::with_tilt_of(f.odom_T_body, *f.settled_attitude), f.settled_accel_bias,
                                     last_bias, frontend.gravity)
              : rsrio::rio::retilted(f.odom_T_body, f.accel_bias, last_bias, frontend.gravity);
      out.push_back(stamped(f.t, backend_->revised(f.t, odom_T_body) * frontend.body_T_radar));
    }
    return out;
  }
  std::vector<double> keyframe_ms;  // the backend's time for each keyframe (pipelined: read after finish())
  double waited_s = 0;              // pipelined: the frontend's time waiting for a free hand-over slot

 private:
  void start(const rsrio::DspProcessor& dsp) {
    backend_.emplace(odometry_->radar(), dsp.grids(), options_);
    if (!pipelined_) return;
    const rsrio::DspGrids& grids = dsp.grids();
    const auto& dsp_options = odometry_->options().dsp;
    handoff_.emplace(2, static_cast<std::size_t>(grids.range_bins * grids.azimuth_bins),
                     static_cast<std::size_t>(grids.range_bins * grids.doppler_bins),
                     static_cast<std::size_t>(dsp_options.cfar.max_detections) *
                         static_cast<std::size_t>(dsp_options.max_angle_peaks),
                     options_);
    backend_->set_cancel_flag(&stop_);
    thread_ = std::thread([this] { run(); });
  }
  // The backend's thread: each candidate as the daemon's BA thread takes it.
  void run() {
    try {
      while (!stop_.load()) {
        if (rsrio::KeyframeCandidate* c = handoff_->next()) {
          const auto t0 = std::chrono::steady_clock::now();
          if (handoff_->hand_to_backend(c, *backend_)) {
            keyframe_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
            std::lock_guard<std::mutex> lock(correction_mutex_);
            correction_ = backend_->correction();
          }
          continue;
        }
        if (input_done_.load() && handoff_->depth() == 0) break;
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    } catch (...) {
      failure_ = std::current_exception();  // read by the main thread after failed_ (release/acquire)
      failed_.store(true);
    }
  }
  void rethrow_failure() {
    if (failed_.load() && failure_) std::rethrow_exception(failure_);
  }

  const std::optional<rsrio::rio::Odometry>& odometry_;
  rsrio::splat::BackendOptions options_;
  const bool pipelined_, alone_;
  std::optional<rsrio::splat::Backend> backend_;
  struct Frame {
    double t;
    gtsam::Pose3 odom_T_body;
    gtsam::Vector3 accel_bias;  // the frontend's then
    std::optional<gtsam::Rot3> settled_attitude = std::nullopt;  // when its state left the window
    gtsam::Vector3 settled_accel_bias = gtsam::Vector3::Zero();
  };
  std::vector<Frame> frames_;  // every frame given
  std::vector<rsrio::rio::SmoothedState> smoothed_;  // finish()'s, in time order
  // The smoothed state published at t (to the rounding of the frontend's clock offset).
  std::optional<gtsam::Pose3> smoothed_at(double t) const {
    const auto it = std::lower_bound(smoothed_.begin(), smoothed_.end(), t - 1e-6,
                                     [](const rsrio::rio::SmoothedState& s, double time) { return s.t < time; });
    if (it == smoothed_.end() || std::abs(it->t - t) >= 1e-6) return std::nullopt;
    return it->world_T_body;
  }
  // The frame the settled state was published with: window_states frames back, at its t (to the
  // rounding of the frontend's clock offset added and taken off again).
  void settle(const rsrio::rio::SettledState& s) {
    const std::size_t back = std::min<std::size_t>(frames_.size(), 1000);
    for (auto it = frames_.rbegin(); it != frames_.rbegin() + static_cast<std::ptrdiff_t>(back); ++it)
      if (std::abs(it->t - s.t) < 1e-6) {
        it->settled_attitude = s.world_T_body.rotation();
        it->settled_accel_bias = s.bias.accelerometer();
        return;
      }
  }
  // Pipelined only.
  std::optional<rsrio::KeyframeHandoff> handoff_;
  std::thread thread_;
  std::atomic<bool> stop_{false}, input_done_{false}, failed_{false};
  std::exception_ptr failure_;
  std::mutex correction_mutex_;
  rsrio::splat::OdomCorrection correction_;  // the newest (identity until the first keyframe: map = odom)
};

// The process's peak resident memory (ru_maxrss), MB: the replay's memory figure.
double peak_memory_mb() {
  struct rusage usage {};
  return getrusage(RUSAGE_SELF, &usage) == 0 ? usage.ru_maxrss / 1024.0 : 0.0;
}

// The backend's pictures: measured | rendered RA and RD of `count` keyframes spread over the run,
// and the Gaussian map from above with the trajectories (ground truth aligned to the end of run's).
// `final_estimate`: the frames as the map has them at the end (the map drawn is that map).
void write_backend_pictures(rsrio::splat::Backend& backend, std::uint64_t count, const std::string& out_dir,
                            const rsrio::eval::Trajectory& frontend, const rsrio::eval::Trajectory& estimate,
                            const rsrio::eval::Trajectory& final_estimate, const rsrio::eval::Trajectory& ground_truth) {
  const auto path = [&](const std::string& name) { return (std::filesystem::path(out_dir) / name).string(); };
  const std::size_t n = backend.keyframes().size();
  std::size_t previous = n;  // none yet
  for (std::uint64_t i = 0; i < count && n > 0; ++i) {
    const std::size_t k = count == 1 ? n - 1 : static_cast<std::size_t>(i * (n - 1) / (count - 1));
    if (k == previous) continue;  // fewer keyframes than pictures asked for
    if (!backend.keyframes()[k].has_images()) continue;  // evicted (max_keyframe_images)
    previous = k;
    char prefix[32];
    std::snprintf(prefix, sizeof prefix, "keyframe_%04zu", k);
    rsrio::splat::write_keyframe_pngs(path(prefix), backend.render_keyframe(k));
  }
  const rsrio::splat::GaussianScene& scene = backend.scene();
  rsrio::eval::PlotPoints points;
  double max_log = -1e300;
  for (std::size_t g = 0; g < scene.size(); ++g) max_log = std::max(max_log, std::log(scene.return_ratio(g)));
  for (std::size_t g = 0; g < scene.size(); ++g) {
    const Eigen::Vector3d m = scene.mean(g);
    points.xy.emplace_back(m.x(), m.y());
    // Darker = stronger return; 30 dB of range (log returns are of power).
    points.weight.push_back(std::clamp(1.0 - (max_log - std::log(scene.return_ratio(g))) / std::log(1e3), 0.05, 1.0));
  }
  std::vector<rsrio::eval::PlotLine> lines{{"frontend", &frontend, cv::Scalar(40, 120, 240)},
                                           {"backend (BA), as published", &estimate, cv::Scalar(200, 90, 20)},
                                           {"backend, end of run", &final_estimate, cv::Scalar(160, 40, 160)}};
  // The ground truth in the frame of the end-of-run trajectory: the one that goes with the map.
  const rsrio::eval::Trajectory& reference = final_estimate.size() >= 3 ? final_estimate : estimate;
  rsrio::eval::Trajectory gt_aligned;
  if (!ground_truth.empty() && reference.size() >= 3) {
    rsrio::eval::Trajectory e, g;
    rsrio::eval::associate(reference, ground_truth, 0.02, e, g);
    if (e.size() >= 3) {
      gt_aligned = rsrio::eval::transformed(ground_truth, rsrio::eval::umeyama(e, g, rsrio::eval::Alignment::kSE3));
      lines.push_back({"ground truth", &gt_aligned, cv::Scalar(60, 160, 60)});
    }
  }
  rsrio::eval::plot_xy(path("map.png"), lines,
                       std::to_string(scene.size()) + " Gaussians (grey, darker = stronger) from " + std::to_string(n) +
                           " keyframes; trajectories of the radar",
                       1000, &points);
}

struct PendingFrame {
  double t_stamp = 0;
  rsrio_msgs::msg::RadarFrame msg;
};

}  // namespace

int main(int argc, char** argv) {
  std::string input, out_dir, backend_name = "none", pictures_text = "3", backend_poses = "frontend", drift_text;
  bool quiet = false, pipelined = false, repeatable = false, truth_wanted = false;
  rsrio::Cli cli(kProgram,
                 "Runs the radar-inertial odometry over a recording as fast as possible and writes\n"
                 "frontend.tum, estimate.tum (with --backend ba also estimate_final.tum), ground_truth.tum\n"
                 "(if the recording has /ground_truth) and stats.json into the output directory. Options\n"
                 "file sections: dsp, ego_velocity, frontend (config/rsrio.yaml lists them with their\n"
                 "defaults) and backend.");
  cli.option("--input", "REC.mcap", "the recording (rsrio-sim or a capture)", &input)
      .option("--out", "DIR", "output directory (made if missing)", &out_dir)
      .option("--backend", "none|ba", "backend after the frontend (default none)", &backend_name)
      .option("--pictures", "N", "with --backend ba: measured vs rendered images of N keyframes (default 3)",
              &pictures_text)
      .option("--backend-poses", "frontend|constant-velocity",
              "with --backend ba: where a new keyframe's pose starts: the frontend's motion (default), or the "
              "backend's own constant-velocity prediction without the frontend (the paper's `no frontend` "
              "ablation; the frontend still runs for frontend.tum)",
              &backend_poses)
      .flag("--pipelined",
            "with --backend ba: the backend on its own thread, as in rsriod (the real-time factor on 2 cores; "
            "corrections are used a keyframe or two later)",
            &pipelined)
      .flag("--repeatable",
            "with --backend ba, sequential: the backend's stages without their time budgets, so that a replay "
            "gives the same trajectory on any machine and load (slower than real time)",
            &repeatable)
      .option("--odometry-drift", "DEG_PER_S,SCALE",
              "the frontend's poses with a heading drift of DEG_PER_S and every step SCALE too long (0.01: 1 %), "
              "as frontend.tum and as the backend takes them: the backend against a frontend that drifts more",
              &drift_text)
      .flag("--odometry-truth",
            "the frontend's poses replaced by the recording's ground truth, as frontend.tum and as the backend "
            "takes them: the backend given a perfect frontend (its own floor)",
            &truth_wanted)
      .flag("--quiet", "no progress line", &quiet);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  rsrio::EstimatorOptions estimator;
  if (auto rc = rsrio::load_program_config(
          cli, kProgram, [&](rsrio::OptionsNode& root) { estimator = rsrio::load_estimator_options(root); }))
    return *rc;
  rsrio::rio::OdometryOptions& options = estimator.odometry;
  rsrio::splat::BackendOptions& backend_options = estimator.backend;
  if (input.empty() || out_dir.empty()) return cli.usage_error("--input and --out are required");
  std::uint64_t pictures = 0;
  if (!rsrio::tools::parse_u64(pictures_text, pictures) || pictures > 1000)
    return cli.usage_error("--pictures: expected a number of keyframes in [0, 1000], got '" + pictures_text + "'");
  if (backend_name != "none" && backend_name != "ba")
    return cli.usage_error("--backend: expected none or ba, got '" + backend_name + "'");
  if (backend_poses != "frontend" && backend_poses != "constant-velocity")
    return cli.usage_error("--backend-poses: expected frontend or constant-velocity, got '" + backend_poses + "'");
  const bool alone = backend_poses == "constant-velocity";
  std::optional<OdometryDrift> drift;
  if (!drift_text.empty()) {
    const auto comma = drift_text.find(',');
    double rate_deg = 0, scale = 0;
    if (comma == std::string::npos || !rsrio::tools::parse_double(drift_text.substr(0, comma), rate_deg) ||
        !rsrio::tools::parse_double(drift_text.substr(comma + 1), scale) || std::abs(rate_deg) > 10 ||
        std::abs(scale) > 0.5)
      return cli.usage_error("--odometry-drift: expected DEG_PER_S,SCALE with |DEG_PER_S| <= 10 and |SCALE| <= 0.5, got '" +
                             drift_text + "'");
    if (alone) return cli.usage_error("--odometry-drift drifts the frontend's poses: not with --backend-poses constant-velocity");
    drift.emplace(rate_deg * std::numbers::pi / 180, scale);
  }
  if (truth_wanted && (drift || alone))
    return cli.usage_error("--odometry-truth replaces the frontend's poses: not with --odometry-drift or --backend-poses "
                           "constant-velocity");
  if (alone && (backend_name != "ba" || pipelined))
    return cli.usage_error(
        "--backend-poses constant-velocity needs --backend ba, sequential (the prediction is the backend's own state)");
  if (pipelined && backend_name != "ba")
    return cli.usage_error("--pipelined runs the backend on its own thread: it needs --backend ba");
  if (options.frontend.whole_run_smoother && (drift || alone || truth_wanted))
    return cli.usage_error("frontend.whole_run_smoother re-solves the frontend's own poses: not with --odometry-drift, "
                           "--odometry-truth or --backend-poses constant-velocity");
  if (repeatable && (backend_name != "ba" || pipelined))
    return cli.usage_error(
        "--repeatable needs --backend ba, sequential (on its own thread the backend's corrections reach the frames "
        "when it is done, which depends on timing)");
  if (repeatable)
    for (rsrio::splat::StageOptions* stage : {&backend_options.pose, &backend_options.mapping, &backend_options.ba})
      stage->time_budget_s = 0;
  // The backend renders on the DSP's grids with the DSP's point spread, from the frontend's extrinsic.
  rsrio::splat::take_frontend_options(backend_options, options);
  {
    std::ostringstream s;
    rsrio::rio::print(s, options);
    if (backend_name == "ba") rsrio::splat::print(s, backend_options);
    spdlog::info("options (--config {}):\n{}", cli.config_path().empty() ? "none: defaults" : cli.config_path(), s.str());
  }

  try {
    std::filesystem::create_directories(out_dir);
    rsrio::RecordingReader reader(input);
    rsrio::RecordedMessage m;
    std::optional<OdometryTruth> truth;
    if (truth_wanted) truth.emplace(input);

    std::optional<rsrio::rio::Odometry> odometry;
    std::unique_ptr<Backend> backend;
    BaBackend* ba = nullptr;
    if (backend_name == "ba") {
      auto b = std::make_unique<BaBackend>(odometry, backend_options, pipelined, alone);
      ba = b.get();
      backend = std::move(b);
    } else {
      backend = std::make_unique<NoBackend>();
    }
    std::optional<rsrio_msgs::msg::RadarConfig> config_msg;
    rsrio::AdcCube cube;
    std::vector<rsrio::rio::ImuSample> imu_before_radar;  // until the first frame makes the odometry
    std::deque<PendingFrame> pending;
    double last_imu_t = -1e300;
    double offset = options.frontend.radar_time_offset_s;
    rsrio::eval::Trajectory frontend_tum, estimate_tum, ground_truth, frontend_smoothed_tum;
    double smoother_s = 0;
    rsrio::rio::FrameInfo replaced;  // the frame as the drifting frontend (--odometry-drift) or the truth gives it
    std::uint64_t frames_without_truth = 0;  // --odometry-truth: frames outside the truth, not given on
    std::map<std::string, std::uint64_t> rejected, damaged;
    std::vector<double> t_dsp, t_ego, t_frontend, t_total;
    std::uint64_t frames = 0, states = 0, imu_count = 0, undecodable = 0, radar_used = 0;
    double sum_points = 0, sum_measurements = 0;
    const auto wall0 = std::chrono::steady_clock::now();
    auto last_progress = wall0;
    double first_t = 0, last_t = 0;

    const auto process = [&](PendingFrame& f) {
      ++frames;
      if (f.msg.flags() & rsrio_msgs::msg::RadarFrame_Constants::FLAG_DAMAGED) {
        ++damaged["flagged_damaged"];
        return;
      }
      if (!odometry) {
        config_msg = f.msg.config();
        rsrio::RadarConfig radar;
        try {
          radar = rsrio::from_msg(f.msg.config());
        } catch (const rsrio::ConfigError& e) {  // the recording's fault, not the command line's
          throw std::runtime_error(input + ": the radar configuration of the first frame is unusable: " + e.what());
        }
        odometry.emplace(radar, options);
        cube = rsrio::AdcCube::for_config(radar);
        for (const auto& s : imu_before_radar) odometry->add_imu(s);
        imu_before_radar.clear();
        first_t = f.t_stamp;
      } else if (!(f.msg.config() == *config_msg)) {
        ++damaged["radar_config_changed"];
        return;
      }
      try {
        rsrio::decode_frame(odometry->radar(), f.msg.adc(), cube);
      } catch (const std::exception& e) {
        ++damaged["adc_size"];
        spdlog::warn("frame {} (stamp {:.6f}): {}", frames - 1, f.t_stamp, e.what());
        return;
      }
      const auto t0 = std::chrono::steady_clock::now();
      const rsrio::rio::FrameInfo& info = odometry->add_radar_frame(f.t_stamp, cube);
      t_dsp.push_back(info.dsp_ms);
      t_ego.push_back(info.ego_ms);
      t_frontend.push_back(info.frontend_ms);
      sum_points += info.points;
      sum_measurements += info.measurements;
      if (!info.ego.ok()) ++rejected[status_key(info.ego.status)];
      if (info.state) {
        ++states;
        radar_used += info.state->radar_used;
        const rsrio::rio::FrameInfo* given = &info;
        if (drift) {
          replaced = info;
          replaced.state->world_T_body = drift->apply(info.t, info.state->world_T_body);
          replaced.world_T_radar = replaced.state->world_T_body * options.frontend.body_T_radar;
          given = &replaced;
        } else if (truth) {
          given = nullptr;
          if (const std::optional<gtsam::Pose3> world_T_radar = truth->world_T_radar(info.t)) {
            replaced = info;
            replaced.world_T_radar = *world_T_radar;
            replaced.state->world_T_body = *world_T_radar * options.frontend.body_T_radar.inverse();
            // The truth's tilt: no accelerometer bias or settled attitude to retilt it by.
            replaced.state->bias = gtsam::imuBias::ConstantBias();
            replaced.state->settled.reset();
            given = &replaced;
          } else {
            ++frames_without_truth;
          }
        }
        if (given) {
          frontend_tum.push_back(stamped(info.t, given->world_T_radar));
          estimate_tum.push_back(stamped(info.t, backend->process(*given, cube)));
        }
      }
      t_total.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      last_t = f.t_stamp;
    };
    const auto progress = [&](bool final) {
      const auto now = std::chrono::steady_clock::now();
      if (quiet || (!final && now - last_progress < std::chrono::seconds(2))) return;
      last_progress = now;
      const double wall = std::chrono::duration<double>(now - wall0).count();
      const double done = last_t - first_t;
      std::fprintf(stderr, "%s: %llu frames, %.1f s of recording in %.1f s (%.2fx real time), %zu rejected%s",
                   kProgram, static_cast<unsigned long long>(frames), done, wall, done / std::max(wall, 1e-9),
                   static_cast<std::size_t>(frames - radar_used), final ? "\n" : "\r");
    };
    // A frame waits until the IMU covers its measurement time (IMU clock = radar clock + offset).
    const auto ready = [&](const PendingFrame& f) {
      const double half = odometry ? 0.5 * rsrio::derive(odometry->radar()).frame_active_time_s : 0.0;
      return last_imu_t >= f.t_stamp - half + offset;
    };

    while (reader.next(m)) {
      if (m.topic == rsrio::topics::kImu) {
        sensor_msgs::msg::Imu imu;
        if (!rsrio::decode(m, imu)) {
          ++undecodable;
          continue;
        }
        const auto& a = imu.linear_acceleration();
        const auto& g = imu.angular_velocity();
        const rsrio::rio::ImuSample s{seconds(imu.header().stamp()), {a.x(), a.y(), a.z()}, {g.x(), g.y(), g.z()}};
        ++imu_count;
        last_imu_t = std::max(last_imu_t, s.t);
        if (odometry)
          odometry->add_imu(s);
        else
          imu_before_radar.push_back(s);
        while (!pending.empty() && ready(pending.front())) {
          process(pending.front());
          pending.pop_front();
          progress(false);
        }
      } else if (m.topic == rsrio::topics::kRadarRaw) {
        PendingFrame f;
        if (!rsrio::decode(m, f.msg)) {
          ++frames;
          ++damaged["undecodable_message"];
          continue;
        }
        f.t_stamp = seconds(f.msg.header().stamp());
        pending.push_back(std::move(f));
        while (!pending.empty() && ready(pending.front())) {
          process(pending.front());
          pending.pop_front();
          progress(false);
        }
      } else if (m.topic == rsrio::topics::kGroundTruth) {
        if (const auto pose = ground_truth_pose(m))
          ground_truth.push_back(*pose);
        else
          ++undecodable;
      }
    }
    for (auto& f : pending) process(f);
    pending.clear();
    // frontend.whole_run_smoother: the whole run as one batch, for the end of run.
    std::vector<rsrio::rio::SmoothedState> smoothed;
    if (options.frontend.whole_run_smoother && odometry) {
      const auto t0 = std::chrono::steady_clock::now();
      try {
        smoothed = odometry->frontend().smooth_whole_run();
      } catch (const std::exception& e) {  // e.g. a run too short to constrain: the rest is still written
        spdlog::warn("frontend.whole_run_smoother: the batch failed ({}); frontend_smoothed.tum not written, the end "
                     "of run from the window's estimates",
                     e.what());
      }
      smoother_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    for (const auto& s : smoothed) frontend_smoothed_tum.push_back(stamped(s.t, s.world_T_body * options.frontend.body_T_radar));
    if (ba != nullptr) ba->finish(smoothed);  // pipelined: the backend's last keyframes
    progress(true);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();

    const auto path = [&](const char* name) { return (std::filesystem::path(out_dir) / name).string(); };
    rsrio::eval::write_tum(path("frontend.tum"), frontend_tum);
    rsrio::eval::write_tum(path("estimate.tum"), estimate_tum);
    if (!frontend_smoothed_tum.empty()) rsrio::eval::write_tum(path("frontend_smoothed.tum"), frontend_smoothed_tum);
    // The truth where each frame's pose is estimated (the IMU-rate stream interpolated at the
    // frames' stamps), so that nearest-stamp association, rsrio-eval's and evo's, pairs exactly.
    std::vector<double> frame_stamps;
    frame_stamps.reserve(frontend_tum.size());
    for (const auto& p : frontend_tum) frame_stamps.push_back(p.t);
    ground_truth = rsrio::eval::resampled(ground_truth, frame_stamps, kGroundTruthMaxGapS);
    if (!ground_truth.empty()) rsrio::eval::write_tum(path("ground_truth.tum"), ground_truth);
    if (ba != nullptr && ba->backend() != nullptr) {
      const rsrio::eval::Trajectory final_tum = ba->final_trajectory();
      rsrio::eval::write_tum(path("estimate_final.tum"), final_tum);
      write_backend_pictures(*ba->backend(), pictures, out_dir, frontend_tum, estimate_tum, final_tum, ground_truth);
    }

    std::string damage;
    if (reader.damage()) {
      damage = reader.damage()->message();
      spdlog::warn("{}: the recording is damaged; replayed up to the damage: {}", input, damage);
    }
    std::uint64_t damaged_total = 0;
    for (const auto& [k, n] : damaged) damaged_total += n;
    std::uint64_t rejected_total = 0;
    for (const auto& [k, n] : rejected) rejected_total += n;

    std::ofstream js(path("stats.json"));
    const auto timing = [&](const char* name, const std::vector<double>& v, bool last) {
      const auto p = percentiles(v);
      js << "    " << json_string(name) << ": {\"p50\": " << p.p50 << ", \"p99\": " << p.p99 << ", \"max\": " << p.max
         << ", \"mean\": " << p.mean << "}" << (last ? "\n" : ",\n");
    };
    js << std::setprecision(6) << "{\n"
       << "  \"input\": " << json_string(input) << ",\n"
       << "  \"backend\": " << json_string(backend_name) << ",\n"
       << "  \"pipelined\": " << (pipelined && ba != nullptr ? "true" : "false") << ",\n"
       << "  \"backend_poses\": " << json_string(ba != nullptr ? backend_poses : "none") << ",\n"
       << "  \"repeatable\": " << (repeatable ? "true" : "false") << ",\n"
       << "  \"odometry_drift\": " << (drift_text.empty() ? "null" : json_string(drift_text)) << ",\n"
       << "  \"odometry_truth\": " << (truth ? "true" : "false") << ",\n"
       << "  \"frames_without_truth\": " << frames_without_truth << ",\n"
       << "  \"waited_for_backend_s\": " << (ba != nullptr ? ba->waited_s : 0.0) << ",\n"
       << "  \"whole_run_smoother_s\": " << smoother_s << ",\n"
       << "  \"frames\": " << frames << ",\n"
       << "  \"states\": " << states << ",\n"
       << "  \"frames_with_radar_factor\": " << radar_used << ",\n"
       << "  \"imu_samples\": " << imu_count << ",\n"
       << "  \"ground_truth_poses\": " << ground_truth.size() << ",\n"
       << "  \"undecodable_messages\": " << undecodable << ",\n"
       << "  \"mean_points_per_frame\": " << (t_dsp.empty() ? 0 : sum_points / t_dsp.size()) << ",\n"
       << "  \"mean_measurements_per_frame\": " << (t_dsp.empty() ? 0 : sum_measurements / t_dsp.size()) << ",\n"
       << "  \"rejected_frames\": {\"total\": " << rejected_total;
    for (const auto& [k, n] : rejected) js << ", " << json_string(k) << ": " << n;
    js << "},\n  \"damaged_frames\": {\"total\": " << damaged_total;
    for (const auto& [k, n] : damaged) js << ", " << json_string(k) << ": " << n;
    js << "},\n  \"recording_damage\": " << (damage.empty() ? "null" : json_string(damage)) << ",\n"
       << "  \"recording_seconds\": " << (last_t - first_t) << ",\n"
       << "  \"wall_seconds\": " << wall << ",\n"
       << "  \"peak_memory_mb\": " << peak_memory_mb() << ",\n"
       << "  \"timings_ms\": {\n";
    timing("dsp", t_dsp, false);
    timing("ego_velocity", t_ego, false);
    timing("frontend", t_frontend, false);
    timing("frame", t_total, ba == nullptr || ba->backend() == nullptr);
    if (ba != nullptr && ba->backend() != nullptr) timing("backend_keyframe", ba->keyframe_ms, true);
    js << "  }";
    if (ba != nullptr && ba->backend() != nullptr) {
      const rsrio::splat::BackendStats& st = ba->backend()->stats();
      js << ",\n  \"backend_stats\": {\"keyframes\": " << st.keyframes << ", \"gaussians\": " << st.gaussians
         << ", \"nan_guard_hits\": " << st.nan_guard_hits << ", \"rejected_frames\": " << st.rejected_frames
         << ", \"pose_s\": " << st.pose.total_s << ", \"mapping_s\": " << st.mapping.total_s
         << ", \"ba_s\": " << st.ba.total_s << ", \"ba_budget_stops\": " << st.ba.budget_stops
         << ", \"pose_iterations\": " << st.pose.iterations << ", \"mapping_iterations\": " << st.mapping.iterations
         << ", \"ba_iterations\": " << st.ba.iterations << ", \"pose_budget_stops\": " << st.pose.budget_stops
         << ", \"mapping_budget_stops\": " << st.mapping.budget_stops
         << ", \"final_ba_s\": " << st.final_ba.total_s << ", \"final_ba_iterations\": " << st.final_ba.iterations
         << ", \"keyframe_images_evicted\": " << st.keyframe_images_evicted
         << ", \"keyframe_points_evicted\": " << st.keyframe_points_evicted
         << ", \"keyframes_dropped\": " << st.keyframes_dropped
         << ", \"occluded_columns\": " << st.occluded_columns << ", \"occluded_pixels\": " << st.occluded_pixels
         << ", \"loop_attempts\": " << st.loop_attempts << ", \"loop_closures\": " << st.loop_closures
         << ", \"loop_rejected_score\": " << st.loop_rejected_score
         << ", \"loop_rejected_ambiguous\": " << st.loop_rejected_ambiguous
         << ", \"loop_below_threshold\": " << st.loop_below_threshold
         << ", \"loop_rejected_refinement\": " << st.loop_rejected_refinement
         << ", \"loop_retries\": " << st.loop_retries << ", \"reference_gaussians\": " << st.reference_gaussians
         << ", \"loop_frozen_alignments\": " << st.loop_frozen_alignments
         << ", \"heading_drift_deg_s\": " << st.heading_drift_deg_s
         << ", \"heading_drift_updates\": " << st.heading_drift_updates
         << "}";
    }
    js << "\n}\n";
    if (!js) throw std::runtime_error(path("stats.json") + ": write failed");

    const auto pd = percentiles(t_dsp), pe = percentiles(t_ego), pf = percentiles(t_frontend);
    spdlog::info("{} frames ({} with a state, {} rejected by the ego-velocity, {} damaged); p50/p99 ms: dsp {:.2f}/{:.2f}, "
                 "ego-velocity {:.2f}/{:.2f}, frontend {:.2f}/{:.2f}; wrote {}",
                 frames, states, rejected_total, damaged_total, pd.p50, pd.p99, pe.p50, pe.p99, pf.p50, pf.p99, out_dir);
  } catch (...) {
    return rsrio::report_program_error(kProgram, std::current_exception());
  }
  return 0;
}
