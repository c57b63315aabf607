// rsrio-splat-bench:
//  1. time of the RadarSplat++ core per keyframe image on the cascade's grid (mmwcas: 128 range
//     x 128 azimuth, 32 Doppler bins) and the xwr1843's: RA render forward, backward, the image
//     loss with its gradient, RD forward and backward, for 2k and 10k Gaussians, float and double.
//     One thread. Numbers are medians over repeated runs.
//     The RD renderer with the backend's kernel (the DSP's Doppler lobe, 0.61 bins), at
//     elevation 0 (RD), with the Gaussians' pixel directions (RD+d; RaRenderer::render_directions,
//     "dirs", also timed) and marginalised over the elevation beam (RD+b: three elevations).
//     The RA render with view-dependent returns (RA+v: RaRenderOptions::view_dependent_return).
//  2. the backend per keyframe (splat::Backend with its default options: pose refinement,
//     mapping, BA) on a synthetic walk through a room of Gaussians whose images are rendered
//     (so the optimisation has the work of a real stretch without the simulator): mean and
//     maximum time per stage and keyframe, Gaussians, and the process's peak memory (ru_maxrss).
//  3. the speed the RD model fits best on simulated cascade frames (sequence 1, meeting room,
//     through the real DSP): the DSP's RD against RD rendered from the DSP's RA at s x the true
//     velocity, s = 0.90 .. 1.10, with each pixel's Doppler at elevation 0, marginalised over the
//     simulator's elevation beam (RdRenderOptions::elevation_sigma_sin), and from the directions
//     of the simulator's scatterers drawn as Gaussians; and, at elevation 0, rendered from the RA
//     those Gaussians render instead of the DSP's (the backend renders its RD from its map's RA).
//     A best s below 1 pulls the backend's keyframe spacing short.
//  4. the pose the RA model fits best on simulated cascade frames through the DSP: the offsets
//     (yaw, forward, left) from the true radar pose at which the backend's RA loss of the
//     simulator's scatterers, drawn as Gaussians with the radar equation's 1/R^4, is lowest;
//     without an elevation gain (the backend's default renderer), with the simulator's two-way
//     elevation beam (elevation_gain_sigma_sin 0.156), and with its whole two-way beam
//     (azimuth too) put into each scatterer's return. A bias here is a pose bias the backend
//     inherits where the map cannot absorb it.
//  5. the revisit alignment's pieces (loop_closure.hpp) at the sizes a revisit has with the
//     default options: match_planar of 10 keyframes' static points against 20 earlier ones' (and
//     over the wider window of BackendOptions::loop_retry_search_*), and
//     close_loops over a 550-keyframe chain (sequence 5's) with 1 and 4 loop constraints, and
//     over an hour's (9000 keyframes) with a loop every 90 keyframes, bounded to the newest
//     keyframes (PoseGraphOptions::max_keyframes, the default) and whole.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <sys/resource.h>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"
#include "rsrio/splat/backend.hpp"
#include "rsrio/splat/loop_closure.hpp"
#include "rsrio/splat/losses.hpp"
#include "rsrio/splat/ra_renderer.hpp"
#include "rsrio/splat/rd_renderer.hpp"
#include "synthetic_frame.hpp"

using namespace rsrio::splat;

namespace {

double median_ms(int reps, const std::function<void()>& f) {
  std::vector<double> t;
  f();  // warm-up (first-touch of buffers)
  for (int r = 0; r < reps; ++r) {
    const auto a = std::chrono::steady_clock::now();
    f();
    const auto b = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double, std::milli>(b - a).count());
  }
  std::nth_element(t.begin(), t.begin() + t.size() / 2, t.end());
  return t[t.size() / 2];
}

// The simulator's default elevation beam (30 deg, which the shipped scenarios keep) as the
// renderers' elevation gain and beam: the two-way power's sigma in sin(elevation).
const double kSimulatorElevationGain = rsrio::sim::RadarModelOptions{}.elevation_power_sigma_sin();

// With (zero) view returns, which the RA+v columns read; the other renders ignore them.
GaussianScene make_scene(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  SceneOptions options;
  options.view_returns = true;
  GaussianScene scene(options);
  for (int i = 0; i < n; ++i) {
    const double r = 1.0 + 16.0 * u(rng);
    const double az = (2 * u(rng) - 1) * 75.0 * std::numbers::pi / 180.0;
    const double z = 0.6 * (u(rng) - 0.5);
    const Eigen::Quaterniond q(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5);
    scene.add({r * std::cos(az), r * std::sin(az), z}, q,
              Eigen::Vector3d(std::log(0.05 + 0.25 * u(rng)), std::log(0.05 + 0.25 * u(rng)),
                              std::log(0.05 + 0.15 * u(rng))),
              std::log(0.1 + u(rng)));
  }
  return scene;
}

template <typename Scalar>
void run(const char* type, const RadarImageGrid& grid, const GaussianScene& scene, int reps) {
  const RaRenderer<Scalar> ra_renderer(grid);
  RdRenderOptions rdo;
  rdo.kernel_sigma_bins = window_power_fwhm_bins("hann") / 2.355;  // the backend's default
  RdRenderer<Scalar> rd_renderer(grid, rdo);
  ImageLoss<Scalar> loss;
  const Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Image<Scalar> ra, rd, grad_ra, grad_rd, target_ra, target_rd;
  SceneGradients grads;
  grads.reset(scene.size(), scene.has_view_returns());
  Vector6d grad_pose = Vector6d::Zero();
  const Eigen::Vector3d velocity(0.8, 0.2, 0);
  RenderStats stats = ra_renderer.render(scene, pose, ra);
  rd_renderer.render(ra, velocity, rd);
  loss.prepare_measurement((ra * Scalar(1.1)).eval(), target_ra);
  loss.prepare_measurement((rd * Scalar(0.9)).eval(), target_rd);
  loss.evaluate(ra, target_ra, &grad_ra);
  loss.evaluate(rd, target_rd, &grad_rd);

  const double t_fwd = median_ms(reps, [&] { ra_renderer.render(scene, pose, ra); });
  const double t_bwd = median_ms(reps, [&] {
    grads.set_zero();
    ra_renderer.backward(scene, pose, grad_ra, &grads, &grad_pose);
  });
  const double t_loss = median_ms(reps, [&] { loss.evaluate(ra, target_ra, &grad_ra); });
  const double t_rd_fwd = median_ms(reps, [&] { rd_renderer.render(ra, velocity, rd); });
  Eigen::Vector3d grad_v = Eigen::Vector3d::Zero();
  const double t_rd_bwd = median_ms(reps, [&] { rd_renderer.backward(ra, velocity, grad_rd, &grad_ra, &grad_v); });
  const double t_rd_loss = median_ms(reps, [&] { loss.evaluate(rd, target_rd, &grad_rd); });
  std::vector<std::uint32_t> all(scene.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint32_t>(i);
  PixelDirections<Scalar> directions;
  const double t_dir = median_ms(reps, [&] { ra_renderer.render_directions(scene, pose, all, directions); });
  const double t_rd_dir_fwd = median_ms(reps, [&] { rd_renderer.render(ra, velocity, rd, &directions); });
  const double t_rd_dir_bwd =
      median_ms(reps, [&] { rd_renderer.backward(ra, velocity, grad_rd, &grad_ra, &grad_v, &directions); });
  RdRenderOptions beam_options = rdo;
  beam_options.elevation_sigma_sin = kSimulatorElevationGain;
  RdRenderer<Scalar> beam_renderer(grid, beam_options);
  const double t_rd_beam_fwd = median_ms(reps, [&] { beam_renderer.render(ra, velocity, rd); });
  const double t_rd_beam_bwd =
      median_ms(reps, [&] { beam_renderer.backward(ra, velocity, grad_rd, &grad_ra, &grad_v); });
  RaRenderOptions view_options;
  view_options.view_dependent_return = true;
  const RaRenderer<Scalar> view_renderer(grid, view_options);
  const double t_view_fwd = median_ms(reps, [&] { view_renderer.render(scene, pose, ra); });
  const double t_view_bwd = median_ms(reps, [&] {
    grads.set_zero();
    view_renderer.backward(scene, pose, grad_ra, &grads, &grad_pose);
  });
  const double total = t_fwd + t_bwd + t_loss + t_rd_fwd + t_rd_bwd + t_rd_loss;
  std::printf("| %6zu | %-6s | %8.0f | %8.3f | %8.3f | %8.3f | %8.3f | %8.3f | %8.3f | %8.3f | %7.0f | %8.3f | %8.3f | %8.3f "
              "| %8.3f | %8.3f | %8.3f | %8.3f |\n",
              scene.size(), type, static_cast<double>(stats.pixels) / static_cast<double>(scene.size()), t_fwd,
              t_bwd, t_loss, t_rd_fwd, t_rd_bwd, t_rd_loss, total, 1000.0 / total, t_dir, t_rd_dir_fwd, t_rd_dir_bwd,
              t_rd_beam_fwd, t_rd_beam_bwd, t_view_fwd, t_view_bwd);
}

void print_render_header() {
  std::printf("| Gauss. | scalar | px/G     | RA fwd   | RA bwd   | RA loss  | RD fwd   | RD bwd   | RD loss  | total    | it/s    "
              "| dirs     | RD+d fwd | RD+d bwd | RD+b fwd | RD+b bwd | RA+v fwd | RA+v bwd |\n");
  std::printf("|--------|--------|----------|----------|----------|----------|----------|----------|----------|----------|---------"
              "|----------|----------|----------|----------|----------|----------|----------|\n");
}

// ---- the speed the RD model fits best on simulated frames

struct SpeedFit {
  int frames = 0;
  // s with the lowest summed loss (parabolic refinement): elevation 0, the elevation beam
  // (RdRenderOptions::elevation_sigma_sin), the scatterers' directions
  double best_flat = 0, best_beam = 0, best_directions = 0;
  double best_rendered_ra = 0;       // elevation 0, from the scatterers' rendered RA (1/R^4, elevation gain)
  double best_rendered_ra_beam = 0;  // ... with the simulator's whole two-way beam in their returns
};

double parabolic_minimum(const std::vector<double>& s, const std::vector<double>& loss) {
  const std::size_t i = static_cast<std::size_t>(std::min_element(loss.begin(), loss.end()) - loss.begin());
  if (i == 0 || i + 1 == loss.size()) return s[i];
  const double l = loss[i - 1], c = loss[i], r = loss[i + 1], den = l - 2 * c + r;
  return den > 0 ? s[i] + 0.5 * (l - r) / den * (s[i + 1] - s[i]) : s[i];
}

// Simulated frames of a scenario through the DSP, with the simulator's static scatterers as
// point-like Gaussians (2 cm, return = RCS): what both model fits below compare.
struct SimulatedStretch {
  rsrio::sim::Scenario scenario;
  std::unique_ptr<rsrio::sim::Simulation> sim;
  std::unique_ptr<rsrio::DspProcessor> dsp;
  RadarImageGrid grid;
  GaussianScene scene;

  SimulatedStretch(const char* scenario_path, double t1) : scenario(rsrio::sim::load_scenario(scenario_path)) {
    scenario.duration_s = t1 + 0.5;
    sim = std::make_unique<rsrio::sim::Simulation>(scenario, 2);
    dsp = std::make_unique<rsrio::DspProcessor>(sim->radar().config());
    grid = RadarImageGrid::from_config(sim->radar().config());
    for (const rsrio::sim::Scatterer& p : sim->scene().static_scatterers())
      scene.add(p.position, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.02)), std::log(p.rcs_m2));
    scene.update_index();
  }
  // Every scatterer with the simulator's two-way beam (its pattern on the amplitude, squared) at
  // this pose in its return.
  GaussianScene with_beam(const Eigen::Isometry3d& world_T_radar) const {
    const Eigen::Isometry3d radar_T_world = world_T_radar.inverse();
    GaussianScene out;
    for (const rsrio::sim::Scatterer& p : sim->scene().static_scatterers()) {
      const Eigen::Vector3d d = radar_T_world * p.position;
      const double az = std::atan2(d.y(), d.x()), el = std::asin(std::clamp(d.z() / d.norm(), -1.0, 1.0));
      const double pattern = scenario.radar_model.beam_pattern(az, el);
      out.add(p.position, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.02)),
              std::log(std::max(1e-30, p.rcs_m2 * pattern * pattern)));
    }
    return out;
  }
  // visit(radar state, world_T_radar, DSP result) for every stride-th frame whose middle lies in
  // [t0, t1] and for which wanted(radar state) holds (simulated only then).
  template <typename Wanted, typename Visit>
  void for_each_frame(double t0, double t1, int stride, Wanted&& wanted, Visit&& visit) {
    rsrio::AdcCube cube;
    for (std::uint64_t k = 0; k < sim->radar_frames(); k += static_cast<std::uint64_t>(stride)) {
      const double t = 0.5 * (sim->radar().frame_start(k) + sim->radar().frame_completion(k));
      if (t < t0 || t > t1) continue;
      const rsrio::sim::RigState radar = sim->radar_state(t);
      if (!wanted(radar)) continue;
      sim->radar().simulate(k, cube);
      Eigen::Isometry3d world_T_radar = Eigen::Isometry3d::Identity();
      world_T_radar.linear() = radar.rotation;
      world_T_radar.translation() = radar.position;
      visit(radar, world_T_radar, dsp->process(cube));
    }
  }
};

SpeedFit fit_rd_speed(const char* scenario_path, double t0, double t1, int stride) {
  SimulatedStretch stretch(scenario_path, t1);
  const RadarImageGrid& grid = stretch.grid;
  // The scatterers drawn as the RA test does (1/R^4, the simulator's elevation beam): only their
  // directions per pixel are used.
  RaRenderOptions ro;
  ro.range_falloff_exponent = 4;
  ro.elevation_gain_sigma_sin = stretch.scenario.radar_model.elevation_power_sigma_sin();
  const RaRenderer<float> ra_renderer(grid, ro);
  RdRenderOptions rdo;
  rdo.kernel_sigma_bins = window_power_fwhm_bins("hann") / 2.355;
  ImageLossOptions lo;
  lo.skip_near_range_bins = BackendOptions{}.skip_near_range_bins;  // the rest: the backend's defaults too
  SpeedFit out;
  std::vector<double> scales;
  for (int k = 0; k <= 40; ++k) scales.push_back(0.90 + 0.005 * k);
  std::vector<double> loss_flat(scales.size(), 0.0), loss_beam(scales.size(), 0.0), loss_dir(scales.size(), 0.0);
  std::vector<double> loss_rendered_ra(scales.size(), 0.0), loss_rendered_ra_beam(scales.size(), 0.0);
  Image<float> rendered, rd_target, ra_rendered, ra_rendered_beam;
  RaRenderOptions beam_in_returns = ro;
  beam_in_returns.elevation_gain_sigma_sin = 0;  // the pattern is in the returns
  const RaRenderer<float> ra_renderer_plain(grid, beam_in_returns);
  PixelDirections<float> directions;
  const auto moving = [](const rsrio::sim::RigState& radar) { return radar.velocity.norm() >= 0.3; };
  stretch.for_each_frame(t0, t1, stride, moving, [&](const rsrio::sim::RigState& radar,
                                                     const Eigen::Isometry3d& world_T_radar, const rsrio::DspResult& r) {
    const Eigen::Vector3d v = radar.rotation.transpose() * radar.velocity;
    const Image<float> ra = Eigen::Map<const Image<float>>(r.ra.data(), grid.range_bins, grid.azimuth_bins);
    const Image<float> rd = Eigen::Map<const Image<float>>(r.rd.data(), grid.range_bins, grid.doppler_bins);
    std::vector<std::uint32_t> near;
    stretch.scene.query_radius(radar.position, grid.range_bins * grid.range_bin_m, near);
    ra_renderer.render_directions(stretch.scene, world_T_radar.inverse(), near, directions);
    // The backend's loss; the RD / RA scale calibrated on each frame at the true velocity (the
    // backend calibrates once, on its first keyframe, the same way).
    rdo.gain = 1.0;
    RdRenderer<float> unit(grid, rdo);
    unit.render(ra, v, rendered);
    RdRenderOptions calibrated = rdo;
    calibrated.gain = rd.cast<double>().sum() / std::max(1e-30, rendered.cast<double>().sum());
    RdRenderer<float> renderer(grid, calibrated);
    RdRenderOptions beam_options = calibrated;
    beam_options.elevation_sigma_sin = stretch.scenario.radar_model.elevation_power_sigma_sin();
    RdRenderer<float> beam(grid, beam_options);
    // The same from the scatterers' own RA, its RD / RA scale calibrated the same way.
    ra_renderer.render(stretch.scene, world_T_radar.inverse(), near, ra_rendered);
    unit.render(ra_rendered, v, rendered);
    RdRenderOptions from_rendered = rdo;
    from_rendered.gain = rd.cast<double>().sum() / std::max(1e-30, rendered.cast<double>().sum());
    RdRenderer<float> rendered_ra_renderer(grid, from_rendered);
    ra_renderer_plain.render(stretch.with_beam(world_T_radar), world_T_radar.inverse(), near, ra_rendered_beam);
    unit.render(ra_rendered_beam, v, rendered);
    RdRenderOptions from_rendered_beam = rdo;
    from_rendered_beam.gain = rd.cast<double>().sum() / std::max(1e-30, rendered.cast<double>().sum());
    RdRenderer<float> rendered_ra_beam_renderer(grid, from_rendered_beam);
    lo.compression.reference = percentile_reference(r.rd, 99.0);
    ImageLoss<float> loss(lo);
    loss.prepare_measurement(rd, rd_target);
    for (std::size_t i = 0; i < scales.size(); ++i) {
      renderer.render(ra, scales[i] * v, rendered);
      loss_flat[i] += loss.evaluate(rendered, rd_target, nullptr);
      beam.render(ra, scales[i] * v, rendered);
      loss_beam[i] += loss.evaluate(rendered, rd_target, nullptr);
      renderer.render(ra, scales[i] * v, rendered, &directions);
      loss_dir[i] += loss.evaluate(rendered, rd_target, nullptr);
      rendered_ra_renderer.render(ra_rendered, scales[i] * v, rendered);
      loss_rendered_ra[i] += loss.evaluate(rendered, rd_target, nullptr);
      rendered_ra_beam_renderer.render(ra_rendered_beam, scales[i] * v, rendered);
      loss_rendered_ra_beam[i] += loss.evaluate(rendered, rd_target, nullptr);
    }
    ++out.frames;
  });
  out.best_flat = parabolic_minimum(scales, loss_flat);
  out.best_beam = parabolic_minimum(scales, loss_beam);
  out.best_directions = parabolic_minimum(scales, loss_dir);
  out.best_rendered_ra = parabolic_minimum(scales, loss_rendered_ra);
  out.best_rendered_ra_beam = parabolic_minimum(scales, loss_rendered_ra_beam);
  return out;
}

// ---- the pose the RA model fits best on simulated frames

// The offsets from the true radar pose (yaw, forward, left) at which the backend's RA loss of the
// simulator's scatterers drawn as Gaussians against the DSP's RA is lowest, summed over frames:
// a bias of the RA model against the DSP (grids, point spread, elevation) is a pose bias the
// backend inherits. Each offset is scanned alone, the others at zero.
struct PoseFit {
  int frames = 0;
  double yaw_deg = 0, forward_m = 0, left_m = 0;
};

// How the scatterers are weighted: elevation_gain_sigma_sin (0: none) in the renderer, or
// (whole_beam) the simulator's two-way beam pattern at the true pose put into each return.
struct BeamModel {
  double elevation_gain_sigma_sin = 0;
  bool whole_beam = false;
};

PoseFit fit_ra_pose(const char* scenario_path, double t0, double t1, int stride, const BeamModel& beam) {
  SimulatedStretch stretch(scenario_path, t1);
  const RadarImageGrid& grid = stretch.grid;
  RaRenderOptions ro;
  ro.range_falloff_exponent = 4;
  ro.elevation_gain_sigma_sin = beam.elevation_gain_sigma_sin;
  const RaRenderer<float> renderer(grid, ro);
  ImageLossOptions lo;
  lo.skip_near_range_bins = BackendOptions{}.skip_near_range_bins;
  std::vector<double> steps;
  for (int k = -12; k <= 12; ++k) steps.push_back(k / 12.0);
  const double yaw_span = 0.6 * std::numbers::pi / 180.0, shift_span = 0.1;
  std::vector<double> loss_yaw(steps.size(), 0.0), loss_forward(steps.size(), 0.0), loss_left(steps.size(), 0.0);
  Image<float> rendered, target;
  PoseFit out;
  const auto every = [](const rsrio::sim::RigState&) { return true; };
  stretch.for_each_frame(t0, t1, stride, every, [&](const rsrio::sim::RigState& radar,
                                                    const Eigen::Isometry3d& world_T_radar, const rsrio::DspResult& r) {
    const Image<float> ra = Eigen::Map<const Image<float>>(r.ra.data(), grid.range_bins, grid.azimuth_bins);
    std::vector<std::uint32_t> near;
    stretch.scene.query_radius(radar.position, grid.range_bins * grid.range_bin_m + 1.0, near);
    // The beam at the true pose; the yaw and shifts scanned change it by little.
    const GaussianScene whole_beam = beam.whole_beam ? stretch.with_beam(world_T_radar) : GaussianScene{};
    const GaussianScene& drawn = beam.whole_beam ? whole_beam : stretch.scene;
    // The rendered scale is the scatterers' RCS, not the DSP's power: one gain per frame, the
    // ratio of the sums at the true pose.
    renderer.render(drawn, world_T_radar.inverse(), near, rendered);
    const float gain = static_cast<float>(ra.cast<double>().sum() / std::max(1e-30, rendered.cast<double>().sum()));
    lo.compression.reference = percentile_reference(r.ra, 99.0);
    ImageLoss<float> loss(lo);
    loss.prepare_measurement(ra, target);
    auto loss_at = [&](double yaw, double forward, double left) {
      Eigen::Isometry3d T = world_T_radar;
      T.translation() += world_T_radar.linear() * Eigen::Vector3d(forward, left, 0);
      T.linear() = world_T_radar.linear() * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      renderer.render(drawn, T.inverse(), near, rendered);
      rendered *= gain;
      return loss.evaluate(rendered, target, nullptr);
    };
    for (std::size_t i = 0; i < steps.size(); ++i) {
      loss_yaw[i] += loss_at(steps[i] * yaw_span, 0, 0);
      loss_forward[i] += loss_at(0, steps[i] * shift_span, 0);
      loss_left[i] += loss_at(0, 0, steps[i] * shift_span);
    }
    ++out.frames;
  });
  out.yaw_deg = parabolic_minimum(steps, loss_yaw) * yaw_span * 180.0 / std::numbers::pi;
  out.forward_m = parabolic_minimum(steps, loss_forward) * shift_span;
  out.left_m = parabolic_minimum(steps, loss_left) * shift_span;
  return out;
}

// ---- backend on a synthetic walk

GaussianScene make_room(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  GaussianScene scene;
  auto add = [&](const Eigen::Vector3d& p, double rho) {
    scene.add(p, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.05)), std::log(rho));
  };
  auto wall = [&](Eigen::Vector3d a, Eigen::Vector3d b) {
    const int n = static_cast<int>((b - a).norm() / 0.3);
    for (int k = 0; k <= n; ++k)
      for (const double z : {-0.6, 0.0, 0.6}) add(a + (b - a) * k / n + Eigen::Vector3d(0, 0, z), std::pow(10.0, -0.5 + u(rng)));
  };
  wall({-3, -4, 0}, {12, -4, 0});
  wall({12, -4, 0}, {12, 5, 0});
  wall({12, 5, 0}, {-3, 5, 0});
  wall({-3, 5, 0}, {-3, -4, 0});
  for (int k = 0; k < 150; ++k) add({-2.5 + 14 * u(rng), -3.5 + 8 * u(rng), 0.6 * (u(rng) - 0.5)}, 0.2 + 2 * u(rng));
  return scene;
}

struct BackendRun {
  std::size_t keyframes = 0, gaussians = 0;
  double pose_mean = 0, mapping_mean = 0, ba_mean = 0, total_mean = 0, total_max = 0;
  double iterations_per_keyframe = 0;  // all stages
  std::uint64_t budget_stops = 0;
  double final_ba_ms_per_view = 0;     // the end-of-run BA: one iteration over one keyframe
};

constexpr int kBenchFinalBaIterations = 10;

BackendRun run_backend(const rsrio::RadarConfig& config, double max_image_range_m, int frames) {
  const rsrio::DspGrids grids = rsrio::DspProcessor(config).grids();
  BackendOptions o;
  o.max_image_range_m = max_image_range_m;
  o.final_ba = StageOptions{kBenchFinalBaIterations, 0.0, 0.0, kBenchFinalBaIterations, 0.1};  // no early stop
  Backend backend(config, grids, o);
  const RadarImageGrid grid = backend.grid();
  const GaussianScene world = make_room(7);
  bench::FrameSynthesiser synthesiser(RadarImageGrid::from_config(config));  // the DSP's full grid
  const double dt = 0.1;
  BackendRun out;
  for (int k = 0; k < frames; ++k) {
    // A walk along x at 0.8 m/s, weaving +-0.5 m.
    const double t = k * dt;
    Eigen::Isometry3d world_T_radar = Eigen::Isometry3d::Identity();
    world_T_radar.translation() = Eigen::Vector3d(0.8 * t, 0.5 * std::sin(0.5 * t), 0);
    const double heading = std::atan2(0.25 * std::cos(0.5 * t), 0.8);
    world_T_radar.linear() = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d v = world_T_radar.linear().transpose() * Eigen::Vector3d(0.8, 0.25 * std::cos(0.5 * t), 0);
    // A third of the scatterers detected, within the range the backend renders.
    const rsrio::DspResult result =
        synthesiser.render(world, world_T_radar, v, 3, grid.range_bins * grid.range_bin_m).view();
    const Eigen::Isometry3d odom = world_T_radar;  // body = radar (identity extrinsic)
    const auto a = std::chrono::steady_clock::now();
    const bool kf = backend.add_frame({t, gtsam::Pose3(gtsam::Rot3(odom.linear()), odom.translation()), &result});
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
    if (kf) {
      out.total_mean += s;
      out.total_max = std::max(out.total_max, s);
    }
  }
  backend.finish();
  const BackendStats& st = backend.stats();
  out.final_ba_ms_per_view = 1e3 * st.final_ba.total_s /
                             static_cast<double>(std::max<std::uint64_t>(1, st.final_ba.iterations * st.keyframes));
  out.keyframes = st.keyframes;
  out.gaussians = st.gaussians;
  const double n = static_cast<double>(std::max<std::uint64_t>(1, st.keyframes));
  out.pose_mean = st.pose.total_s / n;
  out.mapping_mean = st.mapping.total_s / n;
  out.ba_mean = st.ba.total_s / n;
  out.total_mean /= n;
  out.iterations_per_keyframe = static_cast<double>(st.pose.iterations + st.mapping.iterations + st.ba.iterations) / n;
  out.budget_stops = st.pose.budget_stops + st.mapping.budget_stops + st.ba.budget_stops;
  return out;
}

}  // namespace

int main() {
  const RadarImageGrid grid = RadarImageGrid::from_config(rsrio::radar_preset("mmwcas"));
  std::printf("rsrio-splat-bench: mmwcas grid %d range x %d azimuth (%.3f m bins), %d Doppler bins; one thread\n",
              grid.range_bins, grid.azimuth_bins, grid.range_bin_m, grid.doppler_bins);
  std::printf("times in ms per image (median); px/G = pixels evaluated per Gaussian; it/s = full RA+RD iterations per second\n\n");
  print_render_header();
  for (const int n : {2000, 10000}) {
    const GaussianScene scene = make_scene(n, 42);
    const int reps = n > 5000 ? 20 : 50;
    run<float>("float", grid, scene, reps);
    run<double>("double", grid, scene, reps);
  }

  rsrio::RadarConfig small = rsrio::radar_preset("xwr1843");
  const RadarImageGrid grid_small = RadarImageGrid::from_config(small);
  std::printf("\nxwr1843 grid %d range x %d azimuth (%.3f m bins), %d Doppler bins; one thread\n\n", grid_small.range_bins,
              grid_small.azimuth_bins, grid_small.range_bin_m, grid_small.doppler_bins);
  print_render_header();
  run<float>("float", grid_small, make_scene(2000, 42), 50);

  std::printf("\nthe speed the RD model fits best (x the true speed) on sequence 1's cascade frames, 5-35 s, every "
              "3rd frame, through the DSP\n\n");
  const SpeedFit fit = fit_rd_speed("scenarios/seq1_meeting_room.yaml", 5.0, 35.0, 3);
  std::printf("| frames | elevation 0 | elevation beam (sigma %.3f) | scatterers' directions | "
              "elevation 0, scatterers' RA | ... with the whole beam |\n"
              "|--------|-------------|-----------------------------|------------------------|"
              "-----------------------------|-------------------------|\n",
              kSimulatorElevationGain);
  std::printf("| %6d | %11.3f | %27.3f | %22.3f | %27.3f | %23.3f |\n", fit.frames, fit.best_flat, fit.best_beam,
              fit.best_directions, fit.best_rendered_ra, fit.best_rendered_ra_beam);

  std::printf("\nthe pose the RA model fits best (offset from the true radar pose: yaw deg / forward m / left m) on "
              "simulated cascade frames through the DSP, the simulator's scatterers drawn as Gaussians with 1/R^4\n\n");
  std::printf("| stretch                        | frames | no elevation gain        | elevation gain 0.156     | "
              "whole two-way beam       |\n");
  std::printf("|--------------------------------|--------|--------------------------|--------------------------|"
              "--------------------------|\n");
  for (const auto& [label, path, t0, t1, stride] :
       {std::tuple{"sequence 1, 5-35 s (room)", "scenarios/seq1_meeting_room.yaml", 5.0, 35.0, 3},
        std::tuple{"sequence 3, 5-35 s (corridor)", "scenarios/seq3_large_loop.yaml", 5.0, 35.0, 3},
        std::tuple{"sequence 1, 0-2.8 s (standing)", "scenarios/seq1_meeting_room.yaml", 0.0, 2.8, 1}}) {
    int frames = 0;
    std::string cells;
    for (const BeamModel& beam : {BeamModel{0.0, false}, BeamModel{kSimulatorElevationGain, false}, BeamModel{0.0, true}}) {
      const PoseFit pf = fit_ra_pose(path, t0, t1, stride, beam);
      frames = pf.frames;
      char cell[64];
      std::snprintf(cell, sizeof cell, " %+6.3f / %+7.4f / %+7.4f |", pf.yaw_deg, pf.forward_m, pf.left_m);
      cells += cell;
    }
    std::printf("| %-30s | %6d |%s\n", label, frames, cells.c_str());
  }

  std::printf("\nbackend per keyframe (default options: pose %d it, mapping %d it over N_map = %d, BA %d it within "
              "r_BA = %.0f m, at most %d keyframes), synthetic 8 s walk at 0.8 m/s in a 15 m x 9 m room; seconds; "
              "end-of-run BA (final_ba, %d iterations over every keyframe at the end): ms per iteration and keyframe\n\n",
              BackendOptions{}.pose.max_iterations, BackendOptions{}.mapping.max_iterations,
              BackendOptions{}.mapping_keyframes, BackendOptions{}.ba.max_iterations, BackendOptions{}.ba_radius_m,
              BackendOptions{}.ba_max_keyframes, kBenchFinalBaIterations);
  std::printf("| radar   | image range | keyframes | Gaussians | it/KF  | budget stops | pose     | mapping  | BA       | total    | max      | end BA ms/it/KF |\n");
  std::printf("|---------|-------------|-----------|-----------|--------|--------------|----------|----------|----------|----------|----------|-----------------|\n");
  struct Case {
    const char* preset;
    double range;
  };
  for (const Case c : {Case{"xwr1843", 12.0}, Case{"xwr1843", 0.0}, Case{"mmwcas", 12.0}}) {
    rsrio::RadarConfig config = rsrio::radar_preset(c.preset);
    const BackendRun r = run_backend(config, c.range, 80);
    char range[32];
    if (c.range > 0)
      std::snprintf(range, sizeof range, "%.0f m", c.range);
    else
      std::snprintf(range, sizeof range, "full");
    std::printf("| %-7s | %-11s | %9zu | %9zu | %6.0f | %12llu | %8.3f | %8.3f | %8.3f | %8.3f | %8.3f | %15.2f |\n",
                c.preset, range, r.keyframes, r.gaussians, r.iterations_per_keyframe,
                static_cast<unsigned long long>(r.budget_stops), r.pose_mean, r.mapping_mean, r.ba_mean, r.total_mean,
                r.total_max, r.final_ba_ms_per_view);
  }
  {
    // Points on the walls of a 20 m x 10 m room and on clutter, 2 cm noise: a keyframe's ~150
    // static points, 20 earlier keyframes (reference) and 10 new ones (query, 0.3 m / 1 deg off).
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> noise(0.0, 0.02);
    auto cloud = [&](int n) {
      std::vector<Eigen::Vector2d> out;
      for (int i = 0; i < n; ++i) {
        const double a = u(rng);
        const int side = static_cast<int>(u(rng) * 5);
        Eigen::Vector2d p = side == 0   ? Eigen::Vector2d(-10 + 20 * a, -5)
                            : side == 1 ? Eigen::Vector2d(-10 + 20 * a, 5)
                            : side == 2 ? Eigen::Vector2d(10, -5 + 10 * a)
                            : side == 3 ? Eigen::Vector2d(-10, -5 + 10 * a)
                                        : Eigen::Vector2d(-8 + 16 * a, -4 + 8 * u(rng));
        out.push_back(p + Eigen::Vector2d(noise(rng), noise(rng)));
      }
      return out;
    };
    const std::vector<Eigen::Vector2d> reference = cloud(20 * 150);
    // A new pass's cloud, moved by a drift of dx (m) and dyaw (deg).
    auto drifted_cloud = [&](double dx, double dyaw_deg) {
      PlanarCorrection drift;
      drift.dx = dx;
      drift.dyaw = dyaw_deg * std::numbers::pi / 180.0;
      std::vector<Eigen::Vector2d> out;
      for (const Eigen::Vector2d& p : cloud(10 * 150))
        out.push_back((drift.isometry() * Eigen::Vector3d(p.x(), p.y(), 0)).head<2>());
      return out;
    };
    const std::vector<Eigen::Vector2d> query = drifted_cloud(0.3, 1.0);
    PlanarMatch m;
    const double match_ms = median_ms(5, [&] { m = match_planar(reference, query, PlanarMatchOptions{}); });
    // The retry over the wider window (BackendOptions::loop_retry_search_*) for a revisit 1 m and
    // 8 deg off.
    const std::vector<Eigen::Vector2d> far_query = drifted_cloud(1.0, 8.0);
    PlanarMatchOptions retry;
    retry.search_m = BackendOptions{}.loop_retry_search_m;
    retry.search_deg = BackendOptions{}.loop_retry_search_deg;
    PlanarMatch far;
    const double retry_ms = median_ms(3, [&] { far = match_planar(reference, far_query, retry); });
    std::vector<Eigen::Vector3d> chain;
    for (int i = 0; i < 550; ++i) chain.emplace_back(0.4 * i, 0.01 * i, 0.001 * i);
    std::vector<LoopConstraint> loops;
    for (std::size_t k : {200u, 300u, 420u, 549u})
      loops.push_back({k - 190, k, planar_between(chain[k - 190], chain[k]) + Eigen::Vector3d(0.2, 0.1, 0.01)});
    const double graph1_ms = median_ms(5, [&] { close_loops(chain, std::span(loops).first(1), PoseGraphOptions{}); });
    const double graph4_ms = median_ms(5, [&] { close_loops(chain, loops, PoseGraphOptions{}); });
    // An hour of laps (9000 keyframes at 0.4 m, laps of 300 keyframes), a loop closed every 90
    // keyframes: what each closure late in the hour solves (the graph holds every keyframe since
    // the first loop's earlier pass, and every loop).
    std::vector<Eigen::Vector3d> hour;
    for (int i = 0; i < 9000; ++i) hour.emplace_back(0.4 * i, 0.01 * i, 0.001 * i);
    std::vector<LoopConstraint> hour_loops;
    for (std::size_t k = 390; k < hour.size(); k += 90)
      hour_loops.push_back({k - 300, k, planar_between(hour[k - 300], hour[k]) + Eigen::Vector3d(0.02, 0.01, 0.001)});
    const double graph_hour_ms = median_ms(3, [&] { close_loops(hour, hour_loops, PoseGraphOptions{}); });
    PoseGraphOptions whole;
    whole.max_keyframes = 0;
    const double graph_hour_whole_ms = median_ms(3, [&] { close_loops(hour, hour_loops, whole); });
    std::printf("\nrevisit alignment (default PlanarMatchOptions: +-%.1f m, +-%.0f deg); ms, median of 5\n\n",
                PlanarMatchOptions{}.search_m, PlanarMatchOptions{}.search_deg);
    std::printf("| match_planar %4zu vs %4zu points | found dx / dyaw     | close_loops 550 keyframes, 1 loop | 4 loops | "
                "9000 keyframes, %3zu loops: bounded (%zu) / whole |\n",
                query.size(), reference.size(), hour_loops.size(), PoseGraphOptions{}.max_keyframes);
    std::printf("|----------------------------------|---------------------|-----------------------------------|---------|"
                "--------------------------------------------------|\n");
    std::printf("| %32.1f | %5.2f m / %5.2f deg | %33.1f | %7.1f | %39.1f / %6.1f |\n", match_ms, m.correction.dx,
                m.correction.dyaw * 180.0 / std::numbers::pi, graph1_ms, graph4_ms, graph_hour_ms,
                graph_hour_whole_ms);
    std::printf("\nthe retry over +-%.1f m, +-%.0f deg (a revisit 1 m / 8 deg off): %.1f ms, found %.2f m / %.2f deg\n",
                retry.search_m, retry.search_deg, retry_ms, far.correction.dx, far.correction.dyaw * 180.0 / std::numbers::pi);
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("\npeak memory of the process (ru_maxrss): %.1f MB\n", usage.ru_maxrss / 1024.0);
  return 0;
}
