// rsrio-splat-bench: time of the RadarSplat++ core per keyframe image on the cascade's grid
// (mmwcas: 128 range x 128 azimuth, 32 Doppler bins): RA render forward, backward, the image
// loss with its gradient, RD forward and backward, for 2k and 10k Gaussians, float and double.
// One thread. Numbers are medians over repeated runs.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

#include "rsrio/splat/losses.hpp"
#include "rsrio/splat/ra_renderer.hpp"
#include "rsrio/splat/rd_renderer.hpp"

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

GaussianScene make_scene(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  GaussianScene scene;
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
  RdRenderer<Scalar> rd_renderer(grid);
  ImageLoss<Scalar> loss;
  const Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Image<Scalar> ra, rd, grad_ra, grad_rd, target_ra, target_rd;
  SceneGradients grads;
  grads.reset(scene.size());
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
  const double total = t_fwd + t_bwd + t_loss + t_rd_fwd + t_rd_bwd + t_rd_loss;
  std::printf("| %6zu | %-6s | %8.0f | %8.3f | %8.3f | %8.3f | %8.3f | %8.3f | %8.3f | %8.3f | %7.0f |\n",
              scene.size(), type, static_cast<double>(stats.pixels) / static_cast<double>(scene.size()), t_fwd,
              t_bwd, t_loss, t_rd_fwd, t_rd_bwd, t_rd_loss, total, 1000.0 / total);
}

}  // namespace

int main() {
  const RadarImageGrid grid = RadarImageGrid::from_config(rsrio::radar_preset("mmwcas"));
  std::printf("rsrio-splat-bench: mmwcas grid %d range x %d azimuth (%.3f m bins), %d Doppler bins; one thread\n",
              grid.range_bins, grid.azimuth_bins, grid.range_bin_m, grid.doppler_bins);
  std::printf("times in ms per image (median); px/G = pixels evaluated per Gaussian; it/s = full RA+RD iterations per second\n\n");
  std::printf("| Gauss. | scalar | px/G     | RA fwd   | RA bwd   | RA loss  | RD fwd   | RD bwd   | RD loss  | total    | it/s    |\n");
  std::printf("|--------|--------|----------|----------|----------|----------|----------|----------|----------|----------|---------|\n");
  for (const int n : {2000, 10000}) {
    const GaussianScene scene = make_scene(n, 42);
    const int reps = n > 5000 ? 20 : 50;
    run<float>("float", grid, scene, reps);
    run<double>("double", grid, scene, reps);
  }
  return 0;
}
