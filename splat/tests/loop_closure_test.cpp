#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "rsrio/splat/loop_closure.hpp"

using namespace rsrio::splat;
using Catch::Matchers::WithinAbs;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Points along segments (walls), 5 cm apart, with 2 cm of noise and a few outliers: what the
// static CFAR points of a room look like from above.
std::vector<Eigen::Vector2d> walls(const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& segments,
                                   std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 0.02);
  std::uniform_real_distribution<double> anywhere(-6.0, 6.0);
  std::vector<Eigen::Vector2d> out;
  for (const auto& [a, b] : segments) {
    const int n = static_cast<int>((b - a).norm() / 0.05);
    for (int i = 0; i <= n; ++i) out.push_back(a + (b - a) * i / n + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  for (int i = 0; i < 20; ++i) out.emplace_back(anywhere(rng), anywhere(rng));
  return out;
}

std::vector<Eigen::Vector2d> moved(const std::vector<Eigen::Vector2d>& points, const PlanarCorrection& c) {
  const Eigen::Isometry3d T = c.isometry();
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : points) out.push_back((T * Eigen::Vector3d(p.x(), p.y(), 0)).head<2>());
  return out;
}

}  // namespace

TEST_CASE("match_planar recovers the offset of a drifted revisit of a room") {
  std::mt19937_64 rng(7);
  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> room = {
      {{-4, -3}, {5, -3}}, {{5, -3}, {5, 4}}, {{5, 4}, {-4, 4}}, {{-4, 4}, {-4, -3}}, {{1, 0}, {2, 1.5}}};
  const std::vector<Eigen::Vector2d> reference = walls(room, rng);
  // The revisit sees the same walls (other noise), displaced by the drift: 0.35 m, -0.2 m, 2 deg.
  PlanarCorrection drift;
  drift.dx = 0.35;
  drift.dy = -0.2;
  drift.dyaw = 2.0 * kDeg;
  drift.pivot = Eigen::Vector2d(0.5, 0.5);
  const std::vector<Eigen::Vector2d> query = moved(walls(room, rng), drift);

  const PlanarMatch m = match_planar(reference, query, PlanarMatchOptions{});
  REQUIRE(m.valid);
  // The correction must undo the drift: applying it to the drifted query puts every point back.
  const std::vector<Eigen::Vector2d> back = moved(query, m.correction);
  const std::vector<Eigen::Vector2d> truth = moved(query, [&] {
    // The exact inverse of the drift, as a correction about the match's pivot.
    const Eigen::Isometry3d inv = drift.isometry().inverse();
    PlanarCorrection c;
    c.dyaw = -drift.dyaw;
    c.pivot = m.correction.pivot;
    const Eigen::Vector3d p(c.pivot.x(), c.pivot.y(), 0);
    const Eigen::Vector3d t = inv * p - p;
    c.dx = t.x();
    c.dy = t.y();
    return c;
  }());
  double worst = 0;
  for (std::size_t i = 0; i < back.size(); ++i) worst = std::max(worst, (back[i] - truth[i]).norm());
  CHECK(worst < 0.06);  // one cell and one yaw step over +-6 m
  CHECK_THAT(m.correction.dyaw / kDeg, WithinAbs(-2.0, 0.26));
  CHECK(m.score > 0.6);
  CHECK(m.score > 2 * m.score_at_zero);
  CHECK(m.spread_m < 0.05);
  // Yaw is the looser direction at this field's 0.15 m blur: +-0.8 deg turns the walls by 6 cm.
  CHECK(m.spread_deg < 1.0);
}

TEST_CASE("match_planar reports a corridor's along-track ambiguity") {
  std::mt19937_64 rng(11);
  // Two long parallel walls: any shift along them fits as well.
  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> corridor = {{{-10, -1}, {10, -1}},
                                                                             {{-10, 1}, {10, 1}}};
  const std::vector<Eigen::Vector2d> reference = walls(corridor, rng);
  std::vector<Eigen::Vector2d> query;
  for (const auto& p : walls(corridor, rng))
    if (std::abs(p.x()) < 4 && std::abs(p.y()) > 0.5) query.push_back(p + Eigen::Vector2d(0.3, 0.1));
  const PlanarMatch m = match_planar(reference, query, PlanarMatchOptions{});
  REQUIRE(m.valid);
  CHECK_THAT(m.correction.dy, WithinAbs(-0.1, 0.051));  // across: determined
  CHECK(m.spread_m > 0.2);                              // along: not
}

TEST_CASE("match_planar: empty clouds give no match, bad options throw") {
  const std::vector<Eigen::Vector2d> some = {{1, 2}, {3, 4}};
  CHECK_FALSE(match_planar({}, some, PlanarMatchOptions{}).valid);
  CHECK_FALSE(match_planar(some, {}, PlanarMatchOptions{}).valid);
  // A reference 100 m away is out of reach (and makes no 100 m field).
  const std::vector<Eigen::Vector2d> far = {{101, 2}, {103, 4}};
  CHECK_FALSE(match_planar(far, some, PlanarMatchOptions{}).valid);
  CHECK(match_planar(some, some, PlanarMatchOptions{}).valid);
  PlanarMatchOptions bad;
  bad.cell_m = 0;
  CHECK_THROWS_AS(match_planar(some, some, bad), std::invalid_argument);
}

TEST_CASE("close_loops spreads a loop correction along the chain and meets the constraint") {
  // A square loop of 40 poses whose heading drifted by 0.05 deg per step: the last pose should be
  // back on the first's but sits 2 deg and some decimetres off.
  auto compose = [](const Eigen::Vector3d& a, const Eigen::Vector3d& d) {
    return Eigen::Vector3d(a.x() + std::cos(a.z()) * d.x() - std::sin(a.z()) * d.y(),
                           a.y() + std::sin(a.z()) * d.x() + std::cos(a.z()) * d.y(), a.z() + d.z());
  };
  std::vector<Eigen::Vector3d> truth, drifted;
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), q = Eigen::Vector3d::Zero();
  for (int i = 0; i <= 40; ++i) {
    truth.push_back(p);
    drifted.push_back(q);
    const double turn = (i % 10 == 9) ? std::numbers::pi / 2 : 0.0;
    const Eigen::Vector3d step(1.0, 0.0, turn);
    p = compose(p, step);
    q = compose(q, step + Eigen::Vector3d(0, 0, 0.05 * kDeg));
  }
  // The loop: pose 40 is pose 0 (as the truth says), measured against pose 2.
  const LoopConstraint loop{2, 40, planar_between(truth[2], truth[40])};
  const std::vector<Eigen::Vector3d> out = close_loops(drifted, std::vector<LoopConstraint>{loop}, PoseGraphOptions{});
  REQUIRE(out.size() == drifted.size());
  // Before the constraint's `from`, nothing moves.
  for (int i = 0; i <= 2; ++i) CHECK((out[i] - drifted[i]).norm() < 1e-9);
  // Pose 2 stays where it was (drifted by 0.1 deg already): pose 40 must be the constraint's
  // relative pose away from it.
  const Eigen::Vector3d target = compose(drifted[2], loop.relative);
  const double before = (drifted[40].head<2>() - target.head<2>()).norm();
  const double after = (out[40].head<2>() - target.head<2>()).norm();
  CHECK(before > 0.2);
  CHECK(after < 0.01);
  CHECK_THAT(std::remainder(out[40].z() - target.z(), 2 * std::numbers::pi), WithinAbs(0.0, 0.02 * kDeg));
  // The correction grows along the chain instead of jumping at the end.
  const double mid = (out[20].head<2>() - drifted[20].head<2>()).norm();
  CHECK(mid > 0.1 * before);
  CHECK((out[39] - out[40]).head<2>().norm() < 1.05);
  CHECK_THROWS_AS(close_loops(drifted, std::vector<LoopConstraint>{LoopConstraint{5, 5, Eigen::Vector3d::Zero()}}, PoseGraphOptions{}),
                  std::invalid_argument);
}
