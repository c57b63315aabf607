#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <algorithm>
#include <limits>
#include <random>
#include <stdexcept>

#include "rsrio/splat/gaussian_scene.hpp"

using namespace rsrio::splat;

namespace {

std::vector<std::uint32_t> brute_force(const GaussianScene& scene, const Eigen::Vector3d& c, double radius) {
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < scene.size(); ++i)
    if ((scene.mean(i) - c).squaredNorm() <= radius * radius) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

std::vector<Eigen::Vector3d> random_points(std::mt19937_64& rng, int n, double half) {
  std::uniform_real_distribution<double> u(-half, half);
  std::vector<Eigen::Vector3d> p(n);
  for (auto& v : p) v = Eigen::Vector3d(u(rng), u(rng), 0.2 * u(rng));
  return p;
}

}  // namespace

TEST_CASE("The spatial hash returns exactly what a brute-force scan returns", "[splat][scene]") {
  std::mt19937_64 rng(1);
  SceneOptions o;
  o.index_cell_m = 1.5;
  GaussianScene scene(o);
  scene.add_points(random_points(rng, 20000, 30.0), {}, Eigen::Vector3d::Zero());
  std::uniform_real_distribution<double> u(-35, 35), ur(0.0, 12.0);
  std::vector<std::uint32_t> found;
  std::size_t total = 0;
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d c(u(rng), u(rng), 0.1 * u(rng));
    const double radius = q == 0 ? 100.0 : ur(rng);
    scene.query_radius(c, radius, found);
    const auto expected = brute_force(scene, c, radius);
    REQUIRE(found == expected);
    total += found.size();
  }
  CHECK(total > 1000);
  // After the means move, the index follows.
  auto means = scene.mutable_means();
  for (double& m : means) m += 0.7;
  const Eigen::Vector3d c(3, -2, 0);
  scene.query_radius(c, 5.0, found);
  CHECK(found == brute_force(scene, c, 5.0));
  // A map as the backend makes it: a long thin slab (a corridor, 200 m x 5 m x 1 m), queried
  // with the radar's range from inside it, beside it and far away: the query's cells are cut to
  // the slab's, and nothing is lost by the cut.
  GaussianScene slab;
  std::uniform_real_distribution<double> ux(0.0, 200.0), uy(-2.5, 2.5), uz(-0.5, 0.5);
  for (int i = 0; i < 60000; ++i)
    slab.add(Eigen::Vector3d(ux(rng), uy(rng), uz(rng)), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), 0);
  for (const Eigen::Vector3d& at : {Eigen::Vector3d(50, 0, 0), Eigen::Vector3d(0.3, 1, 0.2), Eigen::Vector3d(120, 8, -3),
                                  Eigen::Vector3d(199.9, -2.5, 0.5), Eigen::Vector3d(-30, 0, 0), Eigen::Vector3d(90, 0, 40)}) {
    for (const double radius : {0.1, 2.0, 18.7, 40.0}) {
      slab.query_radius(at, radius, found);
      REQUIRE(found == brute_force(slab, at, radius));
    }
  }
  slab.query_radius(Eigen::Vector3d(50, 0, 0), 18.7, found);
  CHECK(found.size() > 10000);
  slab.query_radius(Eigen::Vector3d(-30, 0, 0), 18.7, found);
  CHECK(found.empty());
  // Points exactly on the radius are inside.
  GaussianScene tiny;
  tiny.add(Eigen::Vector3d(2, 0, 0), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), 0);
  tiny.query_radius(Eigen::Vector3d::Zero(), 2.0, found);
  CHECK(found.size() == 1);
}

TEST_CASE("The cap evicts the Gaussians farthest from the given position", "[splat][scene]") {
  std::mt19937_64 rng(2);
  SceneOptions o;
  o.max_gaussians = 500;
  GaussianScene scene(o);
  const auto points = random_points(rng, 800, 20.0);
  const Eigen::Vector3d center(5, 5, 0);
  const SceneRemap remap = scene.add_points(points, {}, center);
  REQUIRE(scene.size() == 500);
  CHECK(scene.evicted() == 300);
  CHECK(remap.size() == 500);
  CHECK(std::all_of(remap.begin(), remap.end(), [](std::int32_t v) { return v == -1; }));
  std::vector<double> dist;
  for (const auto& p : points) dist.push_back((p - center).norm());
  std::sort(dist.begin(), dist.end());
  double farthest_kept = 0;
  for (std::size_t i = 0; i < scene.size(); ++i) farthest_kept = std::max(farthest_kept, (scene.mean(i) - center).norm());
  CHECK(farthest_kept == dist[499]);
  // Order of survivors is kept; a second batch evicts old far ones.
  const SceneRemap again = scene.add_points(random_points(rng, 100, 3.0), {}, center);
  CHECK(scene.size() == 500);
  CHECK(std::is_sorted(again.begin(), std::find(again.begin(), again.end(), -1)));
}

TEST_CASE("Pruning, densification and the NaN guard", "[splat][scene]") {
  SceneOptions o;
  o.densify_grad_threshold = 1e-3;
  o.densify_split_scale_m = 0.25;
  o.view_returns = true;  // the children and compaction must carry them
  GaussianScene scene(o);
  const Eigen::Quaterniond id = Eigen::Quaterniond::Identity();
  scene.add(Eigen::Vector3d(1, 0, 0), id, Eigen::Vector3d::Constant(std::log(0.1)), std::log(1.0));   // clone
  scene.add(Eigen::Vector3d(2, 0, 0), id, Eigen::Vector3d(std::log(0.5), std::log(0.1), std::log(0.1)),
            std::log(2.0));  // split
  scene.add(Eigen::Vector3d(3, 0, 0), id, Eigen::Vector3d::Constant(std::log(0.1)), std::log(1.0));   // quiet
  scene.add(Eigen::Vector3d(4, 0, 0), id, Eigen::Vector3d::Constant(std::log(0.1)), std::log(1e-12));  // prune: return
  scene.add(Eigen::Vector3d(5, 0, 0), id, Eigen::Vector3d::Constant(std::log(5.0)), std::log(1.0));   // prune: size
  // NaN never enters.
  CHECK_FALSE(scene.add(Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0), id,
                        Eigen::Vector3d::Zero(), 0.0));
  CHECK_FALSE(scene.add(Eigen::Vector3d(1, 1, 1), Eigen::Quaterniond(0, 0, 0, 0), Eigen::Vector3d::Zero(), 0.0));
  CHECK(scene.rejected_non_finite() == 2);
  CHECK(scene.size() == 5);

  SceneRemap remap = scene.prune();
  REQUIRE(scene.size() == 3);
  CHECK(remap == SceneRemap{0, 1, 2});

  SceneGradients g;
  g.reset(scene.size(), scene.has_view_returns());
  g.image_mean_grad_norm = {0.01, 0.02, 1e-5};
  g.visible_count = {2, 4, 1};
  // Each Gaussian's view returns tell it apart: the children must carry their parent's.
  for (std::size_t i = 0; i < scene.size(); ++i)
    for (std::size_t c = 0; c < kViewTerms; ++c) scene.mutable_view_returns()[kViewTerms * i + c] = 0.1 * (i + 1) + 0.01 * c;
  const auto view_of = [&](std::size_t i) {
    return std::vector<double>(scene.view_returns().begin() + kViewTerms * i,
                               scene.view_returns().begin() + kViewTerms * (i + 1));
  };
  const std::vector<double> view_clone = view_of(0), view_split = view_of(1), view_quiet = view_of(2);
  scene.accumulate_densify_stats(g);
  remap = scene.densify(Eigen::Vector3d::Zero());
  // Survivor first (the quiet one), then clone pair, then split pair.
  REQUIRE(scene.size() == 5);
  CHECK(remap == SceneRemap{2, -1, -1, -1, -1});
  CHECK_THAT(scene.return_ratio(1) + scene.return_ratio(2), Catch::Matchers::WithinRel(1.0, 1e-12));
  CHECK_THAT(scene.return_ratio(3) + scene.return_ratio(4), Catch::Matchers::WithinRel(2.0, 1e-12));
  CHECK_THAT(scene.scale(1)[0], Catch::Matchers::WithinRel(0.1, 1e-12));   // clone keeps the size
  CHECK_THAT(scene.scale(3)[0], Catch::Matchers::WithinRel(0.5 / 1.6, 1e-12));  // split shrinks
  CHECK_THAT((scene.mean(1) - scene.mean(2)).norm(), Catch::Matchers::WithinRel(0.1, 1e-9));
  CHECK(std::all_of(scene.densify_count().begin(), scene.densify_count().end(), [](auto c) { return c == 0; }));
  CHECK(view_of(0) == view_quiet);
  CHECK(view_of(1) == view_clone);
  CHECK(view_of(2) == view_clone);
  CHECK(view_of(3) == view_split);
  CHECK(view_of(4) == view_split);

  // A NaN that got in through a parameter block is removed by sanitize() and counted.
  scene.mutable_log_scales()[3 * 2 + 1] = std::numeric_limits<double>::infinity();
  scene.mutable_rotations()[4 * 0] = 0;  // zero quaternion -> identity
  scene.mutable_rotations()[4 * 0 + 1] = 0;
  scene.mutable_rotations()[4 * 0 + 2] = 0;
  scene.mutable_rotations()[4 * 0 + 3] = 0;
  scene.mutable_view_returns()[kViewTerms * 4 + 2] = 1e3;  // clamped to max_view_return
  remap = scene.sanitize();
  CHECK(scene.size() == 4);
  CHECK(scene.removed_non_finite() == 1);
  CHECK(remap == SceneRemap{0, 1, 3, 4});
  CHECK(scene.rotations()[0] == 1.0);
  CHECK(view_of(2) == view_split);  // compacted with the rest of its Gaussian
  CHECK(scene.view_returns()[kViewTerms * 3 + 2] == o.max_view_return);
  // ... and a non-finite view return removes its Gaussian too.
  scene.mutable_view_returns()[kViewTerms * 1 + 3] = std::numeric_limits<double>::quiet_NaN();
  remap = scene.sanitize();
  CHECK(remap == SceneRemap{0, 2, 3});
  CHECK(scene.removed_non_finite() == 2);
}

TEST_CASE("add_points keeps a minimum spacing to existing and new Gaussians", "[splat][scene]") {
  GaussianScene scene;
  AddPointsOptions a;
  a.min_spacing_m = 0.5;
  const std::vector<Eigen::Vector3d> first = {{0, 0, 0}, {0.3, 0, 0}, {1, 0, 0}};
  scene.add_points(first, a, Eigen::Vector3d::Zero());
  CHECK(scene.size() == 2);
  const std::vector<Eigen::Vector3d> second = {{1.2, 0, 0}, {2, 0, 0}, {2.1, 0, 0},
                                               {std::numeric_limits<double>::quiet_NaN(), 0, 0}};
  scene.add_points(second, a, Eigen::Vector3d::Zero());
  CHECK(scene.size() == 3);
  CHECK(scene.rejected_non_finite() == 1);
  CHECK_THROWS(scene.add_points(second, AddPointsOptions{-1.0, 1.0, 0.0}, Eigen::Vector3d::Zero()));
}

TEST_CASE("A scene made without view returns stores none through densify, prune and sanitize", "[splat][scene]") {
  SceneOptions o;
  o.densify_grad_threshold = 1e-3;
  GaussianScene scene(o);
  const Eigen::Quaterniond id = Eigen::Quaterniond::Identity();
  scene.add(Eigen::Vector3d(1, 0, 0), id, Eigen::Vector3d::Constant(std::log(0.1)), 0.0);                       // clone
  scene.add(Eigen::Vector3d(2, 0, 0), id, Eigen::Vector3d(std::log(0.5), std::log(0.1), std::log(0.1)), 0.0);  // split
  scene.add(Eigen::Vector3d(3, 0, 0), id, Eigen::Vector3d::Constant(std::log(0.1)), std::log(1e-12));          // pruned
  CHECK_FALSE(scene.has_view_returns());
  CHECK(scene.view_returns().empty());
  SceneGradients g;
  g.reset(scene.size(), scene.has_view_returns());
  CHECK(g.view_returns.empty());
  g.image_mean_grad_norm = {0.01, 0.02, 0.0};
  g.visible_count = {1, 1, 0};
  scene.accumulate_densify_stats(g);
  CHECK(scene.densify(Eigen::Vector3d::Zero()).size() == 5);
  CHECK(scene.prune().size() == 4);
  scene.mutable_means()[0] = std::numeric_limits<double>::quiet_NaN();
  CHECK(scene.sanitize().size() == 3);
  CHECK(scene.view_returns().empty());
  g.reset(scene.size(), false);
  g.zero_rows(std::vector<std::uint32_t>{0, 2});
  CHECK(g.all_finite(std::vector<std::uint32_t>{0, 2}));
  // Gradients laid out for another scene are refused, not read past.
  SceneGradients with_view;
  with_view.reset(scene.size(), true);
  CHECK_THROWS_AS(g.add(with_view), std::invalid_argument);
}

TEST_CASE("SceneGradients: zero_rows and all_finite(rows) touch only the listed Gaussians", "[splat][scene]") {
  SceneGradients g;
  g.reset(5, true);
  for (auto* v : {&g.means, &g.rotations, &g.log_scales, &g.log_returns, &g.view_returns, &g.image_mean_grad_norm})
    std::fill(v->begin(), v->end(), 1.0);
  std::fill(g.visible_count.begin(), g.visible_count.end(), 3u);
  const std::vector<std::uint32_t> rows{1, 3};
  g.zero_rows(rows);
  for (std::uint32_t i = 0; i < 5; ++i) {
    const double expected = (i == 1 || i == 3) ? 0.0 : 1.0;
    CHECK(g.means[3 * i + 2] == expected);
    CHECK(g.rotations[4 * i + 3] == expected);
    CHECK(g.log_scales[3 * i] == expected);
    CHECK(g.log_returns[i] == expected);
    CHECK(g.view_returns[kViewTerms * i + 1] == expected);
    CHECK(g.image_mean_grad_norm[i] == expected);
    CHECK(g.visible_count[i] == (expected == 0.0 ? 0u : 3u));
  }
  // A NaN outside the rows is not the stage's; inside them it is.
  g.rotations[4 * 2 + 1] = std::numeric_limits<double>::quiet_NaN();
  CHECK(g.all_finite(rows));
  CHECK_FALSE(g.all_finite());
  g.log_scales[3 * 3 + 2] = std::numeric_limits<double>::infinity();
  CHECK_FALSE(g.all_finite(rows));
  CHECK(g.all_finite(std::vector<std::uint32_t>{0, 4}));
  g.view_returns[kViewTerms * 4 + 3] = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(g.all_finite(std::vector<std::uint32_t>{0, 4}));
}

TEST_CASE("copy_from copies a Gaussian's parameters exactly, view terms only into a scene that has them",
          "[splat][scene]") {
  SceneOptions with_view;
  with_view.view_returns = true;
  GaussianScene source(with_view);
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  source.add(Eigen::Vector3d(1, 2, 3), Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.1)), 0.0);
  source.add(Eigen::Vector3d(-4, 5, 0.5), q, Eigen::Vector3d(std::log(0.3), std::log(0.05), std::log(0.2)), -1.5);
  const double terms[kViewTerms] = {0.1, -0.2, 0.3, -0.4};
  std::copy_n(terms, kViewTerms, source.mutable_view_returns().begin() + kViewTerms);

  GaussianScene copy(with_view), plain{SceneOptions{}};
  copy.copy_from(source, 1);
  plain.copy_from(source, 1);
  for (const GaussianScene* s : {&copy, &plain}) {
    REQUIRE(s->size() == 1);
    CHECK(s->mean(0) == source.mean(1));
    CHECK(s->rotation(0).coeffs() == source.rotation(1).coeffs());
    CHECK(s->scale(0) == source.scale(1));
    CHECK(s->return_ratio(0) == source.return_ratio(1));
  }
  CHECK(std::equal(copy.view_returns().begin(), copy.view_returns().end(), terms));
  CHECK(plain.view_returns().empty());
  // The copy is its own: changing the source leaves it as it was.
  source.mutable_means()[3] = 7;
  CHECK(copy.mean(0).x() == -4);
  std::vector<std::uint32_t> near;
  copy.query_radius(Eigen::Vector3d(-4, 5, 0.5), 0.1, near);
  CHECK(near == std::vector<std::uint32_t>{0});
  CHECK_THROWS_AS(copy.copy_from(source, 2), std::out_of_range);
}
