#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <algorithm>
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

// A 9 m x 7 m room with a slanted wall inside it, as wall segments.
const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> kRoom = {
    {{-4, -3}, {5, -3}}, {{5, -3}, {5, 4}}, {{5, 4}, {-4, 4}}, {{-4, 4}, {-4, -3}}, {{1, 0}, {2, 1.5}}};

std::vector<Eigen::Vector2d> moved(const std::vector<Eigen::Vector2d>& points, const PlanarCorrection& c) {
  const Eigen::Isometry3d T = c.isometry();
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : points) out.push_back((T * Eigen::Vector3d(p.x(), p.y(), 0)).head<2>());
  return out;
}

}  // namespace

TEST_CASE("match_planar recovers the offset of a drifted revisit of a room") {
  std::mt19937_64 rng(7);
  const std::vector<Eigen::Vector2d> reference = walls(kRoom, rng);
  // The revisit sees the same walls (other noise), displaced by the drift: 0.35 m, -0.2 m, 2 deg.
  PlanarCorrection drift;
  drift.dx = 0.35;
  drift.dy = -0.2;
  drift.dyaw = 2.0 * kDeg;
  drift.pivot = Eigen::Vector2d(0.5, 0.5);
  const std::vector<Eigen::Vector2d> query = moved(walls(kRoom, rng), drift);

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

TEST_CASE("match_planar with refine_peak places a drift between grid steps") {
  std::mt19937_64 rng(17);
  const std::vector<Eigen::Vector2d> reference = walls(kRoom, rng);
  // A drift half-way between the grid's steps (0.05 m, 0.25 deg) wherever the pivot lands:
  // 2.2 cm and 0.11 deg off the nearest step along x and yaw.
  PlanarCorrection drift;
  drift.dx = 0.372;
  drift.dy = -0.2;
  drift.dyaw = 1.61 * kDeg;
  const std::vector<Eigen::Vector2d> query = moved(walls(kRoom, rng), drift);

  // How far the corrected query lands from where the drift's inverse puts it (worst point).
  auto worst_error = [&](const PlanarMatch& m) {
    const std::vector<Eigen::Vector2d> back = moved(query, m.correction);
    const Eigen::Isometry3d inv = drift.isometry().inverse();
    double worst = 0;
    for (std::size_t i = 0; i < query.size(); ++i)
      worst = std::max(worst, (back[i] - (inv * Eigen::Vector3d(query[i].x(), query[i].y(), 0)).head<2>()).norm());
    return worst;
  };
  PlanarMatchOptions on, off;
  on.refine_peak = true;
  off.refine_peak = false;
  const PlanarMatch grid = match_planar(reference, query, off);
  const PlanarMatch refined = match_planar(reference, query, on);
  REQUIRE(grid.valid);
  REQUIRE(refined.valid);
  // On the grid the yaw is a whole step; refined it is within a fifth of one of the truth.
  CHECK(std::abs(std::remainder(grid.correction.dyaw / kDeg, 0.25)) < 1e-9);
  CHECK_THAT(refined.correction.dyaw / kDeg, WithinAbs(-1.61, 0.05));
  CHECK(std::abs(refined.correction.dyaw / kDeg + 1.61) < 0.5 * std::abs(grid.correction.dyaw / kDeg + 1.61));
  CHECK(worst_error(refined) < 0.6 * worst_error(grid));
  CHECK(worst_error(refined) < 0.02);
  // The score and the spread are the grid's either way.
  CHECK(refined.score == grid.score);
  CHECK(refined.spread_m == grid.spread_m);
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

namespace {

// A square loop of n + 1 poses 0.4 m apart (a keyframe chain round a 23 m square) whose heading
// drifted linearly by `drift_deg` over the loop (a gyro bias): the last pose should be back on the
// first's.
struct DriftedLoop {
  std::vector<Eigen::Vector3d> truth, drifted;
};
Eigen::Vector3d compose(const Eigen::Vector3d& a, const Eigen::Vector3d& d) {
  return Eigen::Vector3d(a.x() + std::cos(a.z()) * d.x() - std::sin(a.z()) * d.y(),
                         a.y() + std::sin(a.z()) * d.x() + std::cos(a.z()) * d.y(), a.z() + d.z());
}
// `first_leg_scale`: the drifted steps of the first side that much longer (a wheel that slipped
// there; 1: none).
DriftedLoop drifted_loop(int n, double drift_deg, double first_leg_scale = 1.0) {
  DriftedLoop l;
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), q = Eigen::Vector3d::Zero();
  for (int i = 0; i <= n; ++i) {
    l.truth.push_back(p);
    l.drifted.push_back(q);
    const double turn = (i % (n / 4) == n / 4 - 1) ? std::numbers::pi / 2 : 0.0;
    p = compose(p, Eigen::Vector3d(0.4, 0.0, turn));
    q = compose(q, Eigen::Vector3d(0.4 * (i < n / 4 ? first_leg_scale : 1.0), 0.0, turn + drift_deg * kDeg / n));
  }
  return l;
}
double yaw_error_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& truth) {
  return std::remainder(a.z() - truth.z(), 2 * std::numbers::pi) / kDeg;
}

}  // namespace

TEST_CASE("close_loops takes a linear heading drift out along the whole chain") {
  const int n = 232;
  const DriftedLoop l = drifted_loop(n, -1.9);
  // The loop: pose n is pose 0 (as the truth says), measured against pose 2.
  const LoopConstraint loop{2, static_cast<std::size_t>(n), planar_between(l.truth[2], l.truth[n])};
  const std::vector<Eigen::Vector3d> out = close_loops(l.drifted, std::vector<LoopConstraint>{loop}, PoseGraphOptions{});
  REQUIRE(out.size() == l.drifted.size());
  // Before the constraint's `from`, nothing moves.
  for (int i = 0; i <= 2; ++i) CHECK((out[i] - l.drifted[i]).norm() < 1e-9);
  CHECK(std::abs(yaw_error_deg(l.drifted[n], l.truth[n])) > 1.8);
  CHECK((l.drifted[n] - l.truth[n]).head<2>().norm() > 0.3);
  // Every pose comes back to the truth, not only the last: the correction grows along the chain
  // as the drift did (pose 2 had drifted by 0.016 deg already).
  double worst_yaw = 0, worst_xy = 0;
  for (int i = 0; i <= n; ++i) {
    worst_yaw = std::max(worst_yaw, std::abs(yaw_error_deg(out[i], l.truth[i])));
    worst_xy = std::max(worst_xy, (out[i] - l.truth[i]).head<2>().norm());
  }
  INFO("worst yaw error " << worst_yaw << " deg, position " << worst_xy << " m");
  CHECK(worst_yaw < 0.1);
  CHECK(worst_xy < 0.05);
  CHECK_THROWS_AS(close_loops(l.drifted, std::vector<LoopConstraint>{LoopConstraint{5, 5, Eigen::Vector3d::Zero()}},
                              PoseGraphOptions{}),
                  std::invalid_argument);
}

TEST_CASE("close_loops averages loops that disagree instead of bending the chain between them") {
  // Two revisits of the same place measured against neighbouring earlier keyframes (0 and 2), as
  // the scan match makes them: one 0.3 deg over, one 0.3 deg under. Met exactly, they would put
  // 0.6 deg between poses 0 and 2 and carry it round the loop (sequence 2 did this with
  // 0.01 deg loop sigmas: the first lap's start came out 0.3-0.8 deg off at the end).
  const int n = 232;
  const DriftedLoop l = drifted_loop(n, -1.9);
  auto measured = [&](std::size_t from, double yaw_error_deg) {
    Eigen::Vector3d r = planar_between(l.truth[from], l.truth[n]);
    r.z() += yaw_error_deg * kDeg;
    return LoopConstraint{from, static_cast<std::size_t>(n), r};
  };
  const std::vector<LoopConstraint> loops{measured(0, 0.3), measured(2, -0.3)};
  const std::vector<Eigen::Vector3d> out = close_loops(l.drifted, loops, PoseGraphOptions{});
  double worst_yaw = 0;
  for (int i = 0; i <= n; ++i) worst_yaw = std::max(worst_yaw, std::abs(yaw_error_deg(out[i], l.truth[i])));
  INFO("worst yaw error " << worst_yaw << " deg; pose 2 " << yaw_error_deg(out[2], l.truth[2]) << ", last "
                          << yaw_error_deg(out[n], l.truth[n]));
  CHECK(std::abs(yaw_error_deg(out[2], l.truth[2])) < 0.15);
  CHECK(std::abs(yaw_error_deg(out[n], l.truth[n])) < 0.15);  // the mean of the two
  CHECK(worst_yaw < 0.2);
  // The tight sigmas of before, for the record: the same loops bend the chain.
  const std::vector<Eigen::Vector3d> tight = close_loops(l.drifted, loops, PoseGraphOptions{0.02, 0.05, 0.005, 0.01});
  CHECK(std::abs(yaw_error_deg(tight[2], l.truth[2])) > 0.4);
}

TEST_CASE("close_loops bounds its graph to the newest keyframes, and to the newest loop's span") {
  const int n = 232;
  const DriftedLoop l = drifted_loop(n, -1.9);
  const LoopConstraint whole{2, static_cast<std::size_t>(n), planar_between(l.truth[2], l.truth[n])};
  PoseGraphOptions bounded;
  bounded.max_keyframes = 100;
  // The newest loop reaches further back than 100 keyframes: the graph takes all of its span,
  // as without the bound.
  const std::vector<LoopConstraint> one{whole};
  const std::vector<Eigen::Vector3d> unbounded_out = close_loops(l.drifted, one, PoseGraphOptions{0.02, 0.15, 0.05, 0.3, 0});
  const std::vector<Eigen::Vector3d> bounded_out = close_loops(l.drifted, one, bounded);
  for (int i = 0; i <= n; ++i) CHECK((bounded_out[i] - unbounded_out[i]).norm() < 1e-9);
  // An old loop (2 -> 120) and a new one (150 -> 232, 83 keyframes): the graph starts at 150,
  // the old loop stays out, nothing before 150 moves, and the new loop is met.
  const LoopConstraint old_loop{2, 120, planar_between(l.truth[2], l.truth[120])};
  const LoopConstraint new_loop{150, static_cast<std::size_t>(n), planar_between(l.truth[150], l.truth[n])};
  const std::vector<LoopConstraint> two{old_loop, new_loop};
  const std::vector<Eigen::Vector3d> out = close_loops(l.drifted, two, bounded);
  for (int i = 0; i < 150; ++i) CHECK((out[i] - l.drifted[i]).norm() < 1e-12);
  auto yaw_off = [&](const Eigen::Vector3d& relative) {
    return std::abs(std::remainder(relative.z() - new_loop.relative.z(), 2 * std::numbers::pi)) / kDeg;
  };
  const Eigen::Vector3d before = planar_between(l.drifted[150], l.drifted[n]), met = planar_between(out[150], out[n]);
  INFO("the new loop's yaw off by " << yaw_off(before) << " deg before, " << yaw_off(met) << " after");
  CHECK(yaw_off(before) > 0.6);
  CHECK(yaw_off(met) < 0.1 * yaw_off(before));
  CHECK((met - new_loop.relative).head<2>().norm() < 0.1 * (before - new_loop.relative).head<2>().norm());
}

TEST_CASE("close_loops: loose heading edges take a length misfit as turns, tight ones as length") {
  // The first side's steps 1 % too long (0.23 m at the end, along x) and no heading drift: the
  // loop's misfit is all in the steps' lengths. Turning the chain moves its end by the lever arm
  // times the turn without straining any step's translation, so edges loose in heading (0.15 deg
  // a step: 232 steps allow 2.3 deg) take much of it as turns; the keyframes then come out turned
  // by tenths of a degree that no drift put there (sequence 4's revisit did this: 0.2 m of misfit,
  // the chain after it turned by up to 0.34 deg). Edges of 0.05 deg keep the headings.
  const int n = 232;
  const DriftedLoop l = drifted_loop(n, 0.0, 1.01);
  const std::vector<LoopConstraint> loop{{2, static_cast<std::size_t>(n), planar_between(l.truth[2], l.truth[n])}};
  PoseGraphOptions tight;
  tight.odometry_sigma_deg = 0.05;
  const std::vector<Eigen::Vector3d> loose_out = close_loops(l.drifted, loop, PoseGraphOptions{});
  const std::vector<Eigen::Vector3d> tight_out = close_loops(l.drifted, loop, tight);
  auto worst_yaw = [&](const std::vector<Eigen::Vector3d>& out) {
    double w = 0;
    for (int i = 0; i <= n; ++i) w = std::max(w, std::abs(yaw_error_deg(out[i], l.truth[i])));
    return w;
  };
  const double end_misfit = (planar_between(l.drifted[2], l.drifted[n]) - loop[0].relative).head<2>().norm();
  INFO("end misfit " << end_misfit << " m; worst yaw error: loose " << worst_yaw(loose_out) << " deg, tight "
                     << worst_yaw(tight_out));
  CHECK(end_misfit > 0.2);
  CHECK(worst_yaw(loose_out) > 0.1);
  CHECK(worst_yaw(tight_out) < 0.3 * worst_yaw(loose_out));
  // The loop is met either way.
  CHECK((planar_between(loose_out[2], loose_out[n]) - loop[0].relative).head<2>().norm() < 0.03);
  CHECK((planar_between(tight_out[2], tight_out[n]) - loop[0].relative).head<2>().norm() < 0.03);
  // What tight edges cost: of a heading drift (1.9 deg round the loop, a gyro bias) they leave a
  // share at the end (the loop's 0.3 deg sigma against 232 steps of 0.05 deg: about 14 %), where
  // the loose ones take it all out (the first case above).
  const DriftedLoop turned = drifted_loop(n, -1.9);
  const std::vector<LoopConstraint> turned_loop{
      {2, static_cast<std::size_t>(n), planar_between(turned.truth[2], turned.truth[n])}};
  const std::vector<Eigen::Vector3d> tight_turned = close_loops(turned.drifted, turned_loop, tight);
  const double left_deg = std::abs(yaw_error_deg(tight_turned[n], turned.truth[n]));
  INFO("heading drift left at the end with tight edges: " << left_deg << " deg of 1.9");
  CHECK(left_deg > 0.1);
  CHECK(left_deg < 0.4);
  PoseGraphOptions bad;
  bad.loop_sigma_deg = 0;
  CHECK_THROWS_AS(close_loops(l.drifted, loop, bad), std::invalid_argument);
  CHECK_THROWS_AS(close_loops(l.drifted, {}, bad), std::invalid_argument);  // before there is a loop too
}
