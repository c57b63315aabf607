#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "rsrio/splat/adam.hpp"

using namespace rsrio::splat;
using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

TEST_CASE("Adam: bias-corrected first step is the learning rate, and it minimises a quadratic", "[splat][adam]") {
  AdamBlock block(2, 0.1);
  std::vector<double> x = {3.0, -2.0};
  std::vector<double> g = {1e-3, -50.0};  // any scale: the first step is lr * sign
  block.step(x, g, {}, AdamOptions{});
  CHECK_THAT(x[0], WithinAbs(2.9, 1e-9));
  CHECK_THAT(x[1], WithinAbs(-1.9, 1e-9));
  for (int it = 0; it < 2000; ++it) {
    g = {2 * (x[0] - 1.0), 2 * (x[1] + 0.5)};
    block.step(x, g, {}, AdamOptions{});
  }
  CHECK_THAT(x[0], WithinAbs(1.0, 1e-3));
  CHECK_THAT(x[1], WithinAbs(-0.5, 1e-3));
}

TEST_CASE("Adam: sparse rows, remap, per-component rates", "[splat][adam]") {
  AdamBlock block(3, 1.0);
  block.set_component_scale({0.1, 0.1, 0.01});
  std::vector<double> x(9, 0.0), g(9, 1.0);
  const std::vector<std::uint32_t> rows = {1};
  block.step(x, g, rows, AdamOptions{});
  CHECK(x[0] == 0.0);
  CHECK_THAT(x[3], WithinAbs(-0.1, 1e-12));
  CHECK_THAT(x[5], WithinAbs(-0.01, 1e-12));
  CHECK(x[6] == 0.0);
  // Row 1 moves to 0, a fresh row appears: the fresh row's first step is again exactly lr.
  block.remap({1, -1});
  CHECK(block.rows() == 2);
  std::vector<double> y(6, 0.0), gy(6, 1.0);
  block.step(y, gy, {}, AdamOptions{});
  CHECK_THAT(y[3], WithinAbs(-0.1, 1e-12));
  CHECK(std::abs(y[0] + 0.1) < 1e-12);  // the moved row had m = g, v = g^2: also a full step
}

TEST_CASE("SplatAdam: the NaN guard skips and counts a step with a non-finite gradient", "[splat][adam]") {
  GaussianScene scene;
  scene.add(Eigen::Vector3d(1, 2, 3), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(-2), 0.0);
  scene.add(Eigen::Vector3d(4, 5, 6), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(-2), 0.0);
  SplatAdam adam(SplatAdamOptions{}, 3);
  SceneGradients g;
  g.reset(scene.size(), scene.has_view_returns());
  std::fill(g.means.begin(), g.means.end(), 1.0);
  g.log_returns[1] = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> pose = {0, 0, 0}, pose_grad = {1, 1, 1};
  SplatAdam::Step step;
  step.scene = &scene;
  step.scene_gradients = &g;
  step.poses = pose;
  step.pose_gradients = pose_grad;
  const std::vector<double> before(scene.means().begin(), scene.means().end());
  CHECK_FALSE(adam.step(step));
  CHECK(adam.skipped() == 1);
  CHECK(std::equal(before.begin(), before.end(), scene.means().begin()));
  CHECK(pose[0] == 0.0);
  // Restricted to Gaussian 0, the NaN of Gaussian 1 is not used: the step goes through.
  const std::vector<std::uint32_t> only0 = {0};
  step.gaussians = only0;
  CHECK(adam.step(step));
  CHECK(adam.steps() == 1);
  CHECK_THAT(scene.means()[0], WithinAbs(1.0 - adam.options().lr_means, 1e-12));
  CHECK(scene.means()[3] == 4.0);
  CHECK_THAT(pose[0], WithinAbs(-adam.options().lr_pose_translation, 1e-12));
  CHECK_THAT(pose[2], WithinAbs(-adam.options().lr_pose_rotation, 1e-12));
  pose_grad[1] = std::numeric_limits<double>::infinity();
  CHECK_FALSE(adam.step(step));
  CHECK(adam.skipped() == 2);
}

TEST_CASE("SplatAdam: the view returns are stepped, guarded and clamped only when they have a rate",
          "[splat][adam]") {
  SceneOptions scene_options;
  scene_options.view_returns = true;
  GaussianScene scene(scene_options);
  scene.add(Eigen::Vector3d(1, 2, 3), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(-2), 0.0);
  SceneGradients g;
  g.reset(scene.size(), scene.has_view_returns());
  std::fill(g.view_returns.begin(), g.view_returns.end(), 1.0);
  SplatAdam::Step step;
  step.scene = &scene;
  step.scene_gradients = &g;

  SplatAdam off(SplatAdamOptions{}, 3);  // lr_view_returns 0: isotropic returns stay so
  CHECK(off.step(step));
  off.remap_scene(SceneRemap{0, -1});
  CHECK(off.view_returns.rows() == 0);  // no optimiser state for them either
  CHECK(std::all_of(scene.view_returns().begin(), scene.view_returns().end(), [](double c) { return c == 0.0; }));
  g.view_returns[2] = std::numeric_limits<double>::quiet_NaN();  // not used: not a reason to skip
  CHECK(off.step(step));

  SplatAdamOptions o;
  o.lr_view_returns = 0.1;
  SplatAdam on(o, 3);
  CHECK_FALSE(on.step(step));  // used now: the guard skips the step
  CHECK(on.skipped() == 1);
  g.view_returns[2] = 1.0;
  CHECK(on.step(step));
  for (const double c : scene.view_returns()) CHECK_THAT(c, WithinAbs(-0.1, 1e-12));
  scene.mutable_view_returns()[1] = -scene.options().max_view_return;
  CHECK(on.step(step));
  CHECK(scene.view_returns()[1] == -scene.options().max_view_return);
  // A structure change carries the moments with the Gaussians.
  on.remap_scene(SceneRemap{-1, 0});
  CHECK(on.view_returns.rows() == 2);

  // A scene made without view returns has nothing for a rate to step: refused, not read past.
  GaussianScene plain;
  plain.add(Eigen::Vector3d(1, 2, 3), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(-2), 0.0);
  SceneGradients pg;
  pg.reset(plain.size(), plain.has_view_returns());
  CHECK(pg.view_returns.empty());
  SplatAdam::Step plain_step;
  plain_step.scene = &plain;
  plain_step.scene_gradients = &pg;
  CHECK(SplatAdam(SplatAdamOptions{}, 3).step(plain_step));
  CHECK_THROWS_AS(SplatAdam(o, 3).step(plain_step), std::invalid_argument);
}
