#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <stdexcept>
#include <utility>

#include "rsrio/splat/ra_renderer.hpp"
#include "splat_test_support.hpp"

using namespace rsrio::splat;
using namespace rsrio::splat::test;

namespace {

// L = sum(weights .* I): backward(weights) must be dL/d(everything).
double weighted_sum(const RaRenderer<double>& renderer, const GaussianScene& scene, const Eigen::Isometry3d& pose,
                    const Image<double>& weights) {
  Image<double> image;
  renderer.render(scene, pose, image);
  return (image.array() * weights.array()).sum();
}

struct GradCheck {
  double mean = 0, rotation = 0, log_scale = 0, log_return = 0, view_return = 0, pose6 = 0, pose3 = 0;
};

GradCheck check_gradients(const RaRenderOptions& options, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const RadarImageGrid grid = small_grid();
  const RaRenderer<double> renderer(grid, options);
  // A planar pose (roll, pitch, z fixed but non-zero) so that the same scene serves both checks.
  PlanarPose planar;
  planar.x = 0.7;
  planar.y = -0.4;
  planar.yaw = 0.3;
  planar.z = 0.2;
  planar.roll = 0.05;
  planar.pitch = -0.03;
  const Eigen::Isometry3d pose = planar.radar_T_world();
  SceneOptions scene_options;
  scene_options.view_returns = options.view_dependent_return;
  GaussianScene scene = random_scene(rng, pose, 8, 2.0, 8.0, 50, 15, 0.05, 0.4, scene_options);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  if (options.view_dependent_return)
    for (double& c : scene.mutable_view_returns()) c = 0.7 * u(rng);
  Image<double> weights(grid.range_bins, grid.azimuth_bins);
  for (Eigen::Index k = 0; k < weights.size(); ++k) weights.data()[k] = u(rng);

  SceneGradients grads;
  grads.reset(scene.size(), scene.has_view_returns());
  Vector6d grad_pose = Vector6d::Zero();
  renderer.backward(scene, pose, weights, &grads, &grad_pose);

  GradCheck out;
  auto param_check = [&](std::span<double> (GaussianScene::*block)(), const std::vector<double>& analytic,
                         int stride, double h) {
    double worst = 0;
    for (std::size_t i = 0; i < scene.size(); ++i) {
      std::vector<double> a(stride), n(stride);
      for (int c = 0; c < stride; ++c) {
        const double x0 = (scene.*block)()[stride * i + c];
        n[c] = central_difference(
            [&](double v) {
              (scene.*block)()[stride * i + c] = v;
              return weighted_sum(renderer, scene, pose, weights);
            },
            x0, h);
        (scene.*block)()[stride * i + c] = x0;
        a[c] = analytic[stride * i + c];
      }
      worst = std::max(worst, relative_error(a, n));
    }
    return worst;
  };
  out.mean = param_check(&GaussianScene::mutable_means, grads.means, 3, 1e-5);
  out.rotation = param_check(&GaussianScene::mutable_rotations, grads.rotations, 4, 1e-6);
  out.log_scale = param_check(&GaussianScene::mutable_log_scales, grads.log_scales, 3, 1e-6);
  out.log_return = param_check(&GaussianScene::mutable_log_returns, grads.log_returns, 1, 1e-6);
  if (scene.has_view_returns())
    out.view_return = param_check(&GaussianScene::mutable_view_returns, grads.view_returns, kViewTerms, 1e-6);

  std::vector<double> numeric6(6);
  for (int k = 0; k < 6; ++k)
    numeric6[k] = central_difference(
        [&](double v) {
          Vector6d d = Vector6d::Zero();
          d[k] = v;
          return weighted_sum(renderer, scene, se3_exp(d) * pose, weights);
        },
        0.0, 1e-6);
  out.pose6 = relative_error(to_vector(grad_pose), numeric6);

  const Eigen::Vector3d analytic3 = planar_gradient(planar, grad_pose);
  std::vector<double> numeric3(3);
  for (int k = 0; k < 3; ++k)
    numeric3[k] = central_difference(
        [&](double v) {
          PlanarPose p = planar;
          (k == 0 ? p.x : k == 1 ? p.y : p.yaw) += v;
          return weighted_sum(renderer, scene, p.radar_T_world(), weights);
        },
        0.0, 1e-6);
  out.pose3 = relative_error(to_vector(analytic3), numeric3);
  std::printf("RA gradcheck (elevation gain %.2f, falloff %.1f, azimuth gain %.0f deg, view return %d): mean %.2e "
              "rotation %.2e log-scale %.2e log-return %.2e view-return %.2e pose6 %.2e pose3 %.2e\n",
              options.elevation_gain_sigma_sin, options.range_falloff_exponent, options.azimuth_gain_sigma_deg,
              options.view_dependent_return ? 1 : 0, out.mean, out.rotation, out.log_scale, out.log_return,
              out.view_return, out.pose6, out.pose3);
  return out;
}

void require_small(const GradCheck& g) {
  CHECK(g.mean < 1e-3);
  CHECK(g.rotation < 1e-3);
  CHECK(g.log_scale < 1e-3);
  CHECK(g.log_return < 1e-3);
  CHECK(g.view_return < 1e-3);
  CHECK(g.pose6 < 1e-3);
  CHECK(g.pose3 < 1e-3);
}

}  // namespace

TEST_CASE("RA gradients match central differences (plain elevation marginal)", "[splat][ra]") {
  RaRenderOptions options;
  options.cutoff_sigma = 7.0;  // truncation below 1e-10: the finite differences see a smooth image
  for (std::uint64_t seed : {1u, 2u, 3u}) require_small(check_gradients(options, seed));
}

TEST_CASE("RA gradients match central differences (elevation gain, range falloff)", "[splat][ra]") {
  RaRenderOptions options;
  options.cutoff_sigma = 7.0;
  options.elevation_gain_sigma_sin = 0.25;
  options.range_falloff_exponent = 2.0;
  options.range_falloff_reference_m = 3.0;
  for (std::uint64_t seed : {4u, 5u}) require_small(check_gradients(options, seed));
}

TEST_CASE("RA gradients match central differences (azimuth gain, with and without the rest)", "[splat][ra]") {
  RaRenderOptions options;
  options.cutoff_sigma = 7.0;
  options.azimuth_gain_sigma_deg = 20.0;  // narrow: the gain's slope matters across the scene
  for (std::uint64_t seed : {6u, 7u}) require_small(check_gradients(options, seed));
  options.elevation_gain_sigma_sin = 0.25;
  options.range_falloff_exponent = 4.0;
  options.range_falloff_reference_m = 3.0;
  require_small(check_gradients(options, 8u));
}

TEST_CASE("RA gradients match central differences (view-dependent return, with and without the rest)",
          "[splat][ra]") {
  RaRenderOptions options;
  options.cutoff_sigma = 7.0;
  options.view_dependent_return = true;
  for (std::uint64_t seed : {9u, 10u}) require_small(check_gradients(options, seed));
  options.elevation_gain_sigma_sin = 0.25;
  options.range_falloff_exponent = 4.0;
  options.range_falloff_reference_m = 3.0;
  options.azimuth_gain_sigma_deg = 30.0;
  require_small(check_gradients(options, 11u));
}

TEST_CASE("A view-dependent return scales a Gaussian by exp(c . b(phi)) at the world azimuth it is seen from",
          "[splat][ra]") {
  const RadarImageGrid grid = small_grid();
  RaRenderOptions on;
  on.view_dependent_return = true;
  const RaRenderer<double> isotropic(grid), viewed(grid, on);
  SceneOptions scene_options;
  scene_options.view_returns = true;
  GaussianScene scene(scene_options);
  REQUIRE(scene.add({3.0, 1.0, 0.0}, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.05)), 0.0));
  const double c[kViewTerms] = {0.4, -0.3, 0.2, 0.5};
  std::copy_n(c, kViewTerms, scene.mutable_view_returns().data());
  // Two radar positions that see the Gaussian from different world azimuths, the second also
  // turned, so that only the world-frame direction (not the radar-frame one) may matter.
  for (const auto& [position, yaw] : {std::pair{Eigen::Vector2d(0.0, 0.0), 0.0},
                                      std::pair{Eigen::Vector2d(0.5, -1.5), 0.6}}) {
    PlanarPose planar;
    planar.x = position.x();
    planar.y = position.y();
    planar.yaw = yaw;
    const Eigen::Isometry3d pose = planar.radar_T_world();
    const double phi = std::atan2(1.0 - position.y(), 3.0 - position.x());
    const double expected =
        std::exp(c[0] * std::cos(phi) + c[1] * std::sin(phi) + c[2] * std::cos(2 * phi) + c[3] * std::sin(2 * phi));
    const GaussianFootprint a = isotropic.footprint(scene, 0, pose), b = viewed.footprint(scene, 0, pose);
    REQUIRE(a.visible);
    REQUIRE(b.visible);
    CHECK_THAT(b.amplitude / a.amplitude, Catch::Matchers::WithinRel(expected, 1e-12));
    CHECK_THAT(b.range_bin, Catch::Matchers::WithinAbs(a.range_bin, 1e-12));
  }
  // A scene made without view returns stores none, and the renderer that would read them refuses
  // it (and gradients without their block) rather than read past its storage.
  GaussianScene plain;
  REQUIRE(plain.add({3.0, 1.0, 0.0}, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.05)), 0.0));
  CHECK(plain.view_returns().empty());
  Image<double> image;
  CHECK_NOTHROW(isotropic.render(plain, Eigen::Isometry3d::Identity(), image));
  CHECK_THROWS_AS(viewed.render(plain, Eigen::Isometry3d::Identity(), image), std::invalid_argument);
  CHECK_THROWS_AS(viewed.footprint(plain, 0, Eigen::Isometry3d::Identity()), std::invalid_argument);
  SceneGradients without;
  without.reset(scene.size(), false);
  CHECK_THROWS_AS(viewed.backward(scene, Eigen::Isometry3d::Identity(), Image<double>::Ones(grid.range_bins, grid.azimuth_bins),
                                  &without, nullptr),
                  std::invalid_argument);
}

TEST_CASE("The azimuth gain dims a Gaussian by the two-way pattern at its azimuth", "[splat][ra]") {
  const RadarImageGrid grid = RadarImageGrid::from_config(rsrio::radar_preset("mmwcas"));
  RaRenderOptions with_gain;
  with_gain.azimuth_gain_sigma_deg = 36.0;
  const RaRenderer<double> plain(grid), dimmed(grid, with_gain);
  for (const double azimuth_deg : {0.0, 20.0, -45.0, 60.0}) {
    const double a = azimuth_deg * std::numbers::pi / 180.0;
    GaussianScene scene;
    scene.add(Eigen::Vector3d(6.0 * std::cos(a), 6.0 * std::sin(a), 0.3), Eigen::Quaterniond::Identity(),
              Eigen::Vector3d::Constant(std::log(0.02)), 0.0);
    const GaussianFootprint f0 = plain.footprint(scene, 0, Eigen::Isometry3d::Identity());
    const GaussianFootprint f1 = dimmed.footprint(scene, 0, Eigen::Isometry3d::Identity());
    REQUIRE(f0.visible);
    REQUIRE(f1.visible);
    const double expected = std::exp(-0.5 * (azimuth_deg / 36.0) * (azimuth_deg / 36.0));
    INFO("azimuth " << azimuth_deg << " deg");
    CHECK_THAT(f1.amplitude / f0.amplitude, Catch::Matchers::WithinRel(expected, 1e-9));
    CHECK(f1.range_bin == f0.range_bin);
    CHECK(f1.azimuth_bin == f0.azimuth_bin);
  }
}

TEST_CASE("point_gains: what the renderer multiplies a point scatterer's return with", "[splat][ra]") {
  // The backend divides new Gaussians' measured power by these: they must be the renderer's.
  const RadarImageGrid grid = RadarImageGrid::from_config(rsrio::radar_preset("mmwcas"));
  RaRenderOptions o;
  o.elevation_gain_sigma_sin = 0.156;
  o.azimuth_gain_sigma_deg = 36.0;
  o.range_falloff_exponent = 4.0;
  o.range_falloff_reference_m = 2.0;
  const RaRenderer<double> plain(grid), full(grid, o);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(5.0, 0.0, 0.0), Eigen::Vector3d(4.0, 2.5, 0.6),
                                  Eigen::Vector3d(3.0, -3.5, -0.4), Eigen::Vector3d(9.0, 1.0, 1.2)}) {
    GaussianScene scene;  // nearly a point: its size changes the elevation gain by (size / sigma)^2
    scene.add(p, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(1e-4)), 0.0);
    const GaussianFootprint f0 = plain.footprint(scene, 0, Eigen::Isometry3d::Identity());
    const GaussianFootprint f1 = full.footprint(scene, 0, Eigen::Isometry3d::Identity());
    REQUIRE(f0.visible);
    REQUIRE(f1.visible);
    const PointGains g = point_gains(o, p);
    INFO("p " << p.transpose());
    CHECK_THAT(g.elevation, Catch::Matchers::WithinRel(std::exp(-0.5 * std::pow(p.z() / p.norm() / 0.156, 2)), 1e-12));
    CHECK_THAT(g.azimuth, Catch::Matchers::WithinRel(std::exp(-0.5 * std::pow(std::atan2(p.y(), p.x()) * 180.0 /
                                                                               std::numbers::pi / 36.0, 2)),
                                                     1e-12));
    CHECK_THAT(g.falloff, Catch::Matchers::WithinRel(std::pow(2.0 / p.norm(), 4.0), 1e-12));
    CHECK_THAT(f1.amplitude / f0.amplitude, Catch::Matchers::WithinRel(g.elevation * g.azimuth * g.falloff, 1e-6));
  }
  const PointGains off = point_gains(RaRenderOptions{}, Eigen::Vector3d(3.0, 2.0, 1.0));
  CHECK(off.elevation == 1.0);
  CHECK(off.azimuth == 1.0);
  CHECK(off.falloff == 1.0);
  const PointGains origin = point_gains(o, Eigen::Vector3d::Zero());
  CHECK(origin.elevation * origin.azimuth * origin.falloff == 1.0);
}

TEST_CASE("A point-like Gaussian peaks at its range and azimuth bin with its return ratio", "[splat][ra]") {
  const RadarImageGrid grid = RadarImageGrid::from_config(rsrio::radar_preset("mmwcas"));
  const RaRenderer<double> renderer(grid);
  std::mt19937_64 rng(7);
  const Eigen::Isometry3d pose = random_pose(rng, 2.0, 0.5);
  for (const auto& [k, a] : {std::pair{30, 40}, std::pair{90, 64}, std::pair{12, 100}}) {
    const double r = grid.range_m(k), s = grid.azimuth_sin(a);
    const Eigen::Vector3d p_radar(r * std::sqrt(1 - s * s), r * s, 0.0);
    GaussianScene scene;
    scene.add(pose.inverse() * p_radar, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(1e-5)),
              std::log(2.5));
    Image<double> image;
    renderer.render(scene, pose, image);
    Eigen::Index rk, ra;
    const double peak = image.maxCoeff(&rk, &ra);
    CHECK(rk == k);
    CHECK(ra == a);
    // The scale is clamped at exp(min_log_scale) ~ 0.1 mm, which widens the lobe by ~1e-5.
    CHECK_THAT(peak, Catch::Matchers::WithinRel(2.5, 1e-4));
  }
  // Left of boresight (y > 0) is above the centre bin, right is below.
  GaussianScene scene;
  scene.add(pose.inverse() * Eigen::Vector3d(5, 2, 0), Eigen::Quaterniond::Identity(),
            Eigen::Vector3d::Constant(std::log(1e-5)), 0.0);
  Image<double> image;
  renderer.render(scene, pose, image);
  Eigen::Index rk, ra;
  image.maxCoeff(&rk, &ra);
  CHECK(ra > grid.azimuth_bins / 2);
}

TEST_CASE("Extended Gaussians keep the energy of a point scatterer", "[splat][ra]") {
  const RadarImageGrid grid = small_grid();
  RaRenderOptions options;
  options.cutoff_sigma = 6.0;
  const RaRenderer<double> renderer(grid, options);
  GaussianScene point, blob;
  const Eigen::Vector3d p(5.0, 0.5, 0.0);
  point.add(p, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(1e-5)), 0.0);
  blob.add(p, Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ())),
           Eigen::Vector3d(std::log(0.3), std::log(0.1), std::log(0.2)), 0.0);
  Image<double> a, b;
  renderer.render(point, Eigen::Isometry3d::Identity(), a);
  renderer.render(blob, Eigen::Isometry3d::Identity(), b);
  // Exact for the continuous integral; the grid sum of a sampled Gaussian is within ~1e-3.
  CHECK_THAT(b.sum(), Catch::Matchers::WithinRel(a.sum(), 1e-2));
  CHECK(b.maxCoeff() < 0.5 * a.maxCoeff());
}

TEST_CASE("Gaussians behind or at the radar render nothing", "[splat][ra]") {
  const RaRenderer<double> renderer(small_grid());
  GaussianScene scene;
  scene.add(Eigen::Vector3d(-3, 0.5, 0), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(-2), 0.0);
  scene.add(Eigen::Vector3d(0, 0, 0), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(-2), 0.0);
  Image<double> image;
  const RenderStats stats = renderer.render(scene, Eigen::Isometry3d::Identity(), image);
  CHECK(stats.gaussians_drawn == 0);
  CHECK(image.cwiseAbs().maxCoeff() == 0.0);
  SceneGradients grads;
  grads.reset(scene.size(), scene.has_view_returns());
  Vector6d gp = Vector6d::Zero();
  renderer.backward(scene, Eigen::Isometry3d::Identity(), Image<double>::Ones(64, 64), &grads, &gp);
  CHECK(grads.all_finite());
  CHECK(gp.isZero());
}

TEST_CASE("Float and double renders agree; a list renders the same as all", "[splat][ra]") {
  std::mt19937_64 rng(11);
  const RadarImageGrid grid = RadarImageGrid::from_config(rsrio::radar_preset("mmwcas"));
  const Eigen::Isometry3d pose = random_pose(rng, 1.0, 0.3);
  const GaussianScene scene = random_scene(rng, pose, 300, 1.0, 15.0, 70, 20);
  Image<double> d;
  Image<float> f;
  RaRenderer<double>(grid).render(scene, pose, d);
  RaRenderer<float>(grid).render(scene, pose, f);
  CHECK((f.cast<double>() - d).cwiseAbs().maxCoeff() < 1e-5 * d.maxCoeff());
  std::vector<std::uint32_t> all(scene.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint32_t>(i);
  Image<double> listed;
  RaRenderer<double>(grid).render(scene, pose, all, listed);
  CHECK((listed - d).cwiseAbs().maxCoeff() == 0.0);
}
