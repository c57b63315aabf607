// rsrio-splat-hour-bench: the backend's memory over an hour of operation (SPEC Sec. 9: a map
// that covers an hour of operation must not grow without bound).
//
// splat::Backend with its default options (the caps: max_gaussians, max_keyframe_images,
// max_keyframe_points, max_keyframes) on the
// cascade's grid follows a walk at 1 m/s, weaving +-0.5 m, along an endless corridor with new
// walls and clutter every metre: exploration, where the map grows (a revisit adds keyframes, not
// Gaussians). A keyframe every 0.4 m: 9000 an hour. The stages' iteration counts are cut to
// --iterations (no time budgets) so that the hour runs in minutes; what the backend holds does
// not depend on them. Every --every minutes of walk it prints the keyframes made and kept, those that still hold
// their images and their static points (with the mean points a keyframe keeps), the Gaussians,
// the heap in use (glibc's mallinfo2: allocated and not freed), the
// resident set, and the backend's mean time per keyframe over the interval (a time that grows
// with the keyframes would be a scan over all of them).
//
// Usage: rsrio-splat-hour-bench [--minutes 60] [--iterations 2] [--every 5]
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/splat/backend.hpp"
#include "synthetic_frame.hpp"

using namespace rsrio::splat;

namespace {

struct Args {
  double minutes = 60;
  int iterations = 2;
  double every_minutes = 5;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (i + 1 >= argc) throw std::invalid_argument(key + ": needs a value");
    const char* value = argv[++i];
    char* end = nullptr;
    const double v = std::strtod(value, &end);
    if (end == value || *end != '\0' || !(v > 0)) throw std::invalid_argument(key + ": not a positive number: " + value);
    if (key == "--minutes")
      a.minutes = v;
    else if (key == "--iterations" && v == std::floor(v) && v <= 1000)
      a.iterations = static_cast<int>(v);
    else if (key == "--iterations")
      throw std::invalid_argument("--iterations: not a whole number from 1 to 1000: " + std::string(value));
    else if (key == "--every")
      a.every_minutes = v;
    else
      throw std::invalid_argument("unknown option " + key + " (usage: [--minutes M] [--iterations N] [--every M])");
  }
  return a;
}

// The corridor, one metre of it at a time (the same metre every time it is asked for): walls at
// y = +-2.5 m with a scatterer every 0.15 m at three heights, and 10 clutter scatterers between
// them; about 52 Gaussians a metre.
void add_corridor_metre(long metre, GaussianScene& world) {
  std::mt19937_64 rng(0x9e3779b97f4a7c15ULL ^ static_cast<std::uint64_t>(metre));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto add = [&](const Eigen::Vector3d& p) {
    world.add(p, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.05)),
              std::log(std::pow(10.0, -0.5 + u(rng))));
  };
  const double x0 = static_cast<double>(metre);
  for (int j = 0; j < 7; ++j)
    for (const double side : {-2.5, 2.5})
      for (const double z : {-0.5, 0.0, 0.5}) add({x0 + 0.15 * j, side + 0.05 * (u(rng) - 0.5), z});
  for (int j = 0; j < 10; ++j) add({x0 + u(rng), -2.2 + 4.4 * u(rng), 0.6 * (u(rng) - 0.5)});
}

// What the radar at x can see: from 3 m behind it to the grid's range ahead.
GaussianScene corridor_around(double x, double range_m) {
  GaussianScene world;
  const long first = static_cast<long>(std::floor(x)) - 3;
  const long last = static_cast<long>(std::ceil(x + range_m)) + 1;
  for (long m = first; m <= last; ++m) add_corridor_metre(m, world);
  return world;
}

double heap_in_use_mb() {
  const struct mallinfo2 mi = mallinfo2();
  return static_cast<double>(mi.uordblks + mi.hblkhd) / (1024.0 * 1024.0);
}

double resident_mb() {
  std::ifstream statm("/proc/self/statm");
  long size = 0, resident = 0;
  statm >> size >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    args = parse(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rsrio-splat-hour-bench: %s\n", e.what());
    return 2;
  }
  const rsrio::RadarConfig config = rsrio::radar_preset("mmwcas");
  const rsrio::DspGrids grids = rsrio::DspProcessor(config).grids();
  BackendOptions o;  // the defaults: caps, keyframe selection, windows
  for (StageOptions* s : {&o.pose, &o.mapping, &o.ba}) {
    s->max_iterations = args.iterations;
    s->time_budget_s = 0;
  }
  o.first_keyframe_mapping_iterations = args.iterations;
  Backend backend(config, grids, o);
  const RadarImageGrid& grid = backend.grid();
  const RadarImageGrid full = RadarImageGrid::from_config(config);
  bench::FrameSynthesiser synthesiser(full);
  const double range_m = grid.range_bins * grid.range_bin_m;

  const double image_kb =
      2.0 * static_cast<double>(grid.range_bins) * (grid.azimuth_bins + grid.doppler_bins) * sizeof(float) / 1024.0;
  std::printf("rsrio-splat-hour-bench: the backend (default options, mmwcas grid %d x %d, %d Doppler bins, %.1f m) "
              "walking 1 m/s along an endless corridor (~52 scatterers a metre) for %.0f min; stages at %d "
              "iterations; caps: max_gaussians %d, max_keyframe_images %d (%.0f kB of images each: measured and "
              "compressed RA and RD), max_keyframe_points %d, max_keyframes %d\n\n",
              grid.range_bins, grid.azimuth_bins, grid.doppler_bins, range_m, args.minutes, args.iterations,
              o.max_gaussians, o.max_keyframe_images, image_kb, o.max_keyframe_points, o.max_keyframes);
  std::printf("| walk (min) | keyframes (kept) | with images | with points (mean) | Gaussians | heap in use (MB) | "
              "resident (MB) | ms / keyframe |\n");
  std::printf("|------------|------------------|-------------|--------------------|-----------|------------------|"
              "---------------|---------------|\n");

  const double dt = 0.1, speed = 1.0;
  const long frames = std::lround(args.minutes * 60.0 / dt);
  const long frames_per_row = std::max(1L, std::lround(args.every_minutes * 60.0 / dt));
  const double heap_start = heap_in_use_mb();
  const rsrio::DspImages* frame = nullptr;
  double interval_s = 0;
  std::size_t interval_keyframes = 0, late_keyframes = 0;
  double late_heap = 0;
  for (long k = 0; k <= frames; ++k) {
    const double t = static_cast<double>(k) * dt;
    Eigen::Isometry3d world_T_radar = Eigen::Isometry3d::Identity();
    world_T_radar.translation() = Eigen::Vector3d(speed * t, 0.5 * std::sin(0.5 * t), 0);
    world_T_radar.linear() =
        Eigen::AngleAxisd(std::atan2(0.25 * std::cos(0.5 * t), speed), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const gtsam::Pose3 odom_T_body(gtsam::Rot3(world_T_radar.linear()), world_T_radar.translation());
    // Images only where the backend makes a keyframe (it reads them there only), decided as it
    // decides (Backend::is_keyframe); the first frame only starts it (no predecessor).
    const auto& keyframes = backend.keyframes();
    const bool due = k > 0 && (keyframes.empty() ||
                               keyframe_due(o, t - keyframes.back().t,
                                            keyframes.back().odom_T_body.inverse() * Eigen::Isometry3d(odom_T_body.matrix())));
    if (due || frame == nullptr) {
      const Eigen::Vector3d v =
          world_T_radar.linear().transpose() * Eigen::Vector3d(speed, 0.25 * std::cos(0.5 * t), 0);
      frame = &synthesiser.render(corridor_around(world_T_radar.translation().x(), range_m), world_T_radar, v, 3,
                                  range_m);
    }
    const rsrio::DspResult result = frame->view();
    const auto a = std::chrono::steady_clock::now();
    const bool keyframe = backend.add_frame({t, odom_T_body, &result});
    if (keyframe != due) {
      std::fprintf(stderr, "rsrio-splat-hour-bench: frame %ld: the backend's keyframe decision (%d) is not the bench's (%d)\n",
                   k, keyframe, due);
      return 1;
    }
    if (keyframe) {
      interval_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
      ++interval_keyframes;
    }
    if (k > 0 && (k % frames_per_row == 0 || k == frames)) {
      std::size_t with_images = 0, with_points = 0, points = 0;
      for (const Keyframe& kf : backend.keyframes()) {
        with_images += kf.has_images() ? 1 : 0;
        with_points += kf.points.empty() ? 0 : 1;
        points += kf.points.size();
      }
      const double heap = heap_in_use_mb();
      std::printf("| %10.1f | %6llu (%6zu) | %11zu | %9zu (%5.0f) | %9zu | %16.1f | %13.1f | %13.1f |\n", t / 60.0,
                  static_cast<unsigned long long>(backend.stats().keyframes), backend.keyframes().size(), with_images,
                  with_points,
                  static_cast<double>(points) / static_cast<double>(std::max<std::size_t>(1, with_points)),
                  backend.scene().size(), heap, resident_mb(),
                  1e3 * interval_s / static_cast<double>(std::max<std::size_t>(1, interval_keyframes)));
      std::fflush(stdout);
      interval_s = 0;
      interval_keyframes = 0;
      if (late_keyframes == 0 && 4 * k >= 3 * frames) {
        late_keyframes = backend.stats().keyframes;
        late_heap = heap;
      }
    }
  }
  const double heap_end = heap_in_use_mb();
  const std::size_t keyframes_end = backend.stats().keyframes;
  std::printf("\nheap in use: %.1f MB before the backend's first frame, %.1f MB at the end; over the last quarter of "
              "the walk %+.0f bytes per keyframe made (a keyframe kept without its images and points: %zu bytes, "
              "until max_keyframes drops the oldest of those); nan guard hits %llu\n",
              heap_start, heap_end,
              keyframes_end > late_keyframes
                  ? (heap_end - late_heap) * 1024.0 * 1024.0 / static_cast<double>(keyframes_end - late_keyframes)
                  : 0.0,
              sizeof(Keyframe), static_cast<unsigned long long>(backend.stats().nan_guard_hits));
  return 0;
}
