// Evaluation metrics on cases whose answers are worked out by hand.
#include "rsrio/eval/trajectory.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <catch2/catch_approx.hpp>
#include <catch2/catch_test_macros.hpp>

#include "rsrio/eval/plot.hpp"
#include "scratch_dir.hpp"

using Catch::Approx;
using namespace rsrio::eval;

namespace {
Trajectory from_points(const std::vector<Eigen::Vector3d>& pts, double yaw_deg = 0) {
  Trajectory t;
  for (std::size_t i = 0; i < pts.size(); ++i)
    t.push_back({double(i), pts[i], Eigen::Quaterniond(Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()))});
  return t;
}
}  // namespace

TEST_CASE("a constant offset: 0.1 m without alignment, zero after SE(3) alignment", "[eval]") {
  const auto ref = from_points({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}});
  auto est = ref;
  for (auto& p : est) p.p.x() += 0.1;
  const auto none = ape(ref, est, Alignment::kNone);
  CHECK(none.translation_m.rmse == Approx(0.1));
  CHECK(none.translation_m.max == Approx(0.1));
  CHECK(none.rotation_deg.max == Approx(0.0).margin(1e-9));
  const auto se3 = ape(ref, est, Alignment::kSE3);
  CHECK(se3.translation_m.rmse == Approx(0.0).margin(1e-9));
  CHECK(se3.path_length_m == Approx(3.0));
}

TEST_CASE("a 90 degree turn about the origin: sqrt(2) per point unaligned, zero aligned", "[eval]") {
  const auto ref = from_points({{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}});
  const auto est = transformed(ref, Eigen::Isometry3d(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())));
  const auto none = ape(ref, est, Alignment::kNone);
  CHECK(none.translation_m.rmse == Approx(std::sqrt(2.0)));
  CHECK(none.rotation_deg.mean == Approx(90.0));
  for (auto a : {Alignment::kSE3, Alignment::kSE2}) {
    const auto r = ape(ref, est, a);
    CHECK(r.translation_m.rmse == Approx(0.0).margin(1e-9));
    CHECK(r.rotation_deg.max == Approx(0.0).margin(1e-6));
  }
}

TEST_CASE("SE(2) alignment leaves a tilt that SE(3) removes", "[eval]") {
  const auto ref = from_points({{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {1, 1, 1}});
  const auto est = transformed(ref, Eigen::Isometry3d(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX())));
  CHECK(ape(ref, est, Alignment::kSE3).translation_m.rmse == Approx(0.0).margin(1e-9));
  CHECK(ape(ref, est, Alignment::kSE2).translation_m.rmse > 0.05);
  // The tilt SE(2) leaves is all tilt, no heading: 0.2 rad about x.
  const auto se2 = ape(ref, est, Alignment::kSE2);
  CHECK(se2.tilt_deg.max == Approx(0.2 * 180 / M_PI));
  CHECK(se2.tilt_deg.min == Approx(0.2 * 180 / M_PI));
  CHECK(se2.heading_deg.max == Approx(0.0).margin(1e-9));
  CHECK(ape(ref, est, Alignment::kSE3).tilt_deg.max == Approx(0.0).margin(1e-6));
}

TEST_CASE("APE rotation splits into heading about the vertical and tilt", "[eval]") {
  // Each estimated attitude turned in the world frame by a heading error (alternating sign) and
  // then tilted about an axis that turns with the pose: Rz(h) R(axis, t) R_ref. The positions are
  // the reference's, so no alignment moves anything.
  const auto ref = from_points({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 2, 0}, {2, 2, 0}}, 30.0);
  auto est = ref;
  const double h = 0.3 * M_PI / 180, t = 0.2 * M_PI / 180;
  for (std::size_t i = 0; i < est.size(); ++i) {
    const double sign = i % 2 == 0 ? 1.0 : -1.0;
    const Eigen::Vector3d axis(std::cos(0.7 * double(i)), std::sin(0.7 * double(i)), 0.0);
    est[i].q = Eigen::AngleAxisd(sign * h, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(t, axis) * ref[i].q;
  }
  for (auto a : {Alignment::kNone, Alignment::kSE3}) {
    const auto r = ape(ref, est, a);
    CHECK(r.heading_deg.rmse == Approx(0.3));
    CHECK(r.heading_deg.mean == Approx(0.0).margin(1e-9));
    CHECK(r.heading_deg.max == Approx(0.3));
    CHECK(r.heading_deg.min == Approx(-0.3));
    CHECK(r.tilt_deg.rmse == Approx(0.2));
    CHECK(r.tilt_deg.std == Approx(0.0).margin(1e-9));
    // Small angles: the whole rotation is their root sum of squares.
    CHECK(r.rotation_deg.rmse == Approx(std::hypot(0.3, 0.2)).epsilon(1e-4));
  }
  // A heading error past 180 deg wraps: a 181 deg turn anticlockwise is 179 deg clockwise.
  auto turned = ref;
  for (auto& p : turned) p.q = Eigen::AngleAxisd(181 * M_PI / 180, Eigen::Vector3d::UnitZ()) * p.q;
  CHECK(ape(ref, turned, Alignment::kNone).heading_deg.mean == Approx(-179.0));
}

TEST_CASE("error statistics as numpy computes them", "[eval]") {
  const auto s = stats({1, 2, 3, 4});
  CHECK(s.mean == Approx(2.5));
  CHECK(s.median == Approx(2.5));
  CHECK(s.rmse == Approx(std::sqrt(30.0 / 4)));
  CHECK(s.std == Approx(std::sqrt(1.25)));
  CHECK(s.min == 1);
  CHECK(s.max == 4);
}

TEST_CASE("RPE per metre: a 10 % scale error gives 0.1 m per metre", "[eval]") {
  std::vector<Eigen::Vector3d> pts, scaled;
  for (int i = 0; i <= 5; ++i) {
    pts.emplace_back(i, 0, 0);
    scaled.emplace_back(1.1 * i, 0, 0);
  }
  const auto r = rpe(from_points(pts), from_points(scaled), 1.0);
  CHECK(r.translation_m.count == 5);
  CHECK(r.translation_m.rmse == Approx(0.1));
  CHECK(r.rotation_deg.max == Approx(0.0).margin(1e-9));
}

TEST_CASE("RPE takes its pairs from the estimate's path, as evo_rpe", "[eval]") {
  // evo_rpe tum g e --delta 1 --delta_unit m on these files: pairs (0,1), (1,3); errors 0.1414, 0.1
  const auto ref = from_points({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 1, 0}});
  const auto est = from_points({{0, 0.1, 0}, {1.1, 0, 0}, {2, 0.1, 0}, {3.2, 1, 0}});
  const auto r = rpe(ref, est, 1.0);
  CHECK(r.translation_m.count == 2);
  CHECK(r.translation_m.rmse == Approx(0.122474).epsilon(1e-5));
  CHECK(r.translation_m.min == Approx(0.1));
  CHECK(r.translation_m.max == Approx(0.141421).epsilon(1e-5));
  // evo_ape tum g e -a: rmse 0.085139, max 0.097996; with -r angle_deg: 2.165615 deg
  const auto a = ape(ref, est, Alignment::kSE3);
  CHECK(a.translation_m.rmse == Approx(0.085139).epsilon(1e-5));
  CHECK(a.translation_m.max == Approx(0.097996).epsilon(1e-5));
  CHECK(a.rotation_deg.rmse == Approx(2.165615).epsilon(1e-5));
}

TEST_CASE("TUM files round-trip, association pairs nearest stamps, bad lines are named", "[eval]") {
  const rsrio::testing::ScratchDir dir("trajectory_test");
  const std::string path = dir.file("trajectory.tum");
  const auto ref = from_points({{0, 0, 0}, {1, 2, 3}, {4, 5, 6}}, 30);
  write_tum(path, ref);
  const auto back = read_tum(path);
  REQUIRE(back.size() == 3);
  CHECK(back[1].p.isApprox(ref[1].p));
  CHECK(back[2].q.isApprox(ref[2].q, 1e-8));
  Trajectory est = ref;
  for (auto& p : est) p.t += 0.004;  // within evo's 10 ms
  est.push_back({10.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity()});  // nothing near it in ref
  Trajectory ra, ea;
  associate(ref, est, 0.01, ra, ea);
  CHECK(ra.size() == 3);
  CHECK(ea[2].t == Approx(2.004));
  // A dense reference (200 Hz ground truth) and a sparse estimate (10 Hz): one pair per estimate,
  // each with the nearest reference stamp (evo pairs from the shorter trajectory).
  Trajectory dense, sparse;
  for (int i = 0; i < 400; ++i) dense.push_back({i * 0.005, Eigen::Vector3d(i, 0, 0), Eigen::Quaterniond::Identity()});
  for (int i = 0; i < 20; ++i) sparse.push_back({i * 0.1 + 0.001, Eigen::Vector3d(20 * i, 0, 0), Eigen::Quaterniond::Identity()});
  associate(dense, sparse, 0.01, ra, ea);
  REQUIRE(ea.size() == 20);
  CHECK(ea[7].t == Approx(0.701));
  CHECK(ra[7].t == Approx(0.700));
  std::ofstream(path) << "0 1 2 3 0 0 0 1\n1 2 3\n";
  try {
    read_tum(path);
    FAIL("no error");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find(path + ":2:") != std::string::npos);
  }
  const std::string png = path + ".png";
  plot_xy(png, {{"reference", &ref, {0, 0, 0}}}, "test");
  CHECK(std::filesystem::file_size(png) > 1000);
}

namespace {
// A walk through waypoints at `speed` m/s, sampled every dt s, standing `pause_s` at each
// waypoint (and at the start).
Trajectory walk(const std::vector<Eigen::Vector2d>& waypoints, double speed, double dt, double pause_s) {
  Trajectory t;
  double time = 0;
  auto add = [&](const Eigen::Vector2d& p) {
    t.push_back({time, Eigen::Vector3d(p.x(), p.y(), 0), Eigen::Quaterniond::Identity()});
    time += dt;
  };
  for (std::size_t w = 0; w + 1 < waypoints.size(); ++w) {
    for (double s = 0; s < pause_s; s += dt) add(waypoints[w]);
    const Eigen::Vector2d a = waypoints[w], b = waypoints[w + 1];
    const int n = static_cast<int>(std::lround((b - a).norm() / (speed * dt)));
    for (int k = 0; k < n; ++k) add(a + (b - a) * (double(k) / n));
  }
  for (double s = 0; s < pause_s; s += dt) add(waypoints.back());
  return t;
}
}  // namespace

TEST_CASE("resampled: a turn sampled at 200 Hz, read back between its samples exactly; no pose off its ends or in a gap",
          "[eval]") {
  // Turning at 1 rad/s round a 2 m circle, sampled every 5 ms from t = 0 to 1 s, with a 0.1 s gap.
  const auto at = [](double t) {
    return StampedPose{t, Eigen::Vector3d(2 * std::cos(t), 2 * std::sin(t), 0.5),
                       Eigen::Quaterniond(Eigen::AngleAxisd(t, Eigen::Vector3d::UnitZ()))};
  };
  Trajectory truth;
  for (int i = 0; i <= 200; ++i)
    if (i <= 100 || i >= 120) truth.push_back(at(i * 0.005));
  const std::vector<double> stamps{-0.01, 0.0019, 0.2519, 0.52, 0.7519, 1.0, 1.01};
  const Trajectory r = resampled(truth, stamps, 0.02);
  REQUIRE(r.size() == 4);  // not -0.01 and 1.01 (off the ends), not 0.52 (in the gap)
  for (const auto& p : r) {
    INFO("t " << p.t);
    const StampedPose want = at(p.t);
    // The rotation interpolates exactly (constant rate); the position along the chord, at most
    // 2 m x (5 ms x 1 rad/s)^2 / 8 = 6e-6 m inside the arc.
    CHECK(p.q.angularDistance(want.q) < 1e-12);
    CHECK((p.p - want.p).norm() < 7e-6);
  }
  CHECK(r[0].t == 0.0019);
  CHECK(r[3].t == 1.0);
  // Paired by nearest stamp against the 200 Hz truth, 1.9 ms off: 1.9 mrad of heading at 1 rad/s;
  // against the resampled truth, none.
  Trajectory est{at(0.0019), at(0.2519), at(0.7519)}, a, b;
  associate(truth, est, 0.01, a, b);
  REQUIRE(a.size() == 3);
  CHECK(ape(a, b, Alignment::kNone).rotation_deg.max == Approx(0.0019 * 180 / M_PI).epsilon(1e-3));
  associate(resampled(truth, {0.0019, 0.2519, 0.7519}, 0.02), est, 0.01, a, b);
  REQUIRE(a.size() == 3);
  CHECK(ape(a, b, Alignment::kNone).rotation_deg.max < 1e-9);
}

TEST_CASE("track_errors: a lead along the track and an offset to its left, either way, not counted standing",
          "[eval]") {
  // Out along +x and back along -x, standing at the ends. The estimate runs 5 cm ahead and 2 cm
  // to the left of the direction of travel; standing, it is 1 m off (must not count).
  const Trajectory ref = walk({{0, 0}, {4, 0}, {0, 0}}, 0.5, 0.1, 2.0);
  Trajectory est = ref;
  std::size_t moving = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const std::size_t a = i > 0 ? i - 1 : i, b = i + 1 < ref.size() ? i + 1 : i;
    const double vx = (ref[b].p.x() - ref[a].p.x()) / (ref[b].t - ref[a].t);
    if (std::abs(vx) >= 0.2) {
      const double dir = vx > 0 ? 1.0 : -1.0;
      est[i].p += Eigen::Vector3d(0.05 * dir, 0.02 * dir, 0);
      ++moving;
    } else {
      est[i].p += Eigen::Vector3d(1.0, 1.0, 0);
    }
  }
  const TrackErrors e = track_errors(ref, est);
  CHECK(e.along_m.count == moving);
  CHECK(moving > 100);
  CHECK(e.along_m.mean == Approx(0.05));
  CHECK(e.along_m.rmse == Approx(0.05));
  CHECK(e.across_m.mean == Approx(0.02));
  CHECK(e.across_m.max == Approx(0.02));
  // The estimate as the reference: nothing along or across.
  const TrackErrors zero = track_errors(ref, ref);
  CHECK(zero.along_m.rmse == Approx(0.0).margin(1e-12));
  CHECK(zero.across_m.rmse == Approx(0.0).margin(1e-12));
  CHECK_THROWS_AS(track_errors(ref, Trajectory(ref.begin(), ref.end() - 1)), std::invalid_argument);
}

TEST_CASE("straight_legs: split at stops and at turns; a walk short in y only shows on the y legs", "[eval]") {
  const std::vector<Eigen::Vector2d> square{{0, 0}, {4, 0}, {4, 2}, {0, 2}, {0, 0}};
  for (const double pause : {2.0, 0.0}) {  // with stops at the corners, and turning without one
    INFO("pause " << pause);
    const Trajectory ref = walk(square, 0.5, 0.1, pause);
    Trajectory est = ref;
    for (auto& p : est) p.p.y() *= 0.98;
    const auto legs = straight_legs(ref, est);
    REQUIRE(legs.size() == 4);
    const double headings[] = {0, 90, 180, -90};
    for (std::size_t k = 0; k < 4; ++k) {
      INFO("leg " << k);
      CHECK(std::abs(std::remainder(legs[k].heading_deg - headings[k], 360.0)) < 1e-6);
      const bool along_y = k % 2 == 1;
      // The legs lose a sample at each end to the stop or the turn (0.05 m at 0.5 m/s, 0.1 s).
      CHECK(legs[k].ref_m == Approx(along_y ? 2.0 : 4.0).margin(0.11));
      CHECK(legs[k].est_m / legs[k].ref_m == Approx(along_y ? 0.98 : 1.0).epsilon(1e-9));
      CHECK(legs[k].t_end > legs[k].t_begin + 3.0);
    }
  }
  // A leg shorter than min_duration_s is left out.
  const Trajectory ref = walk({{0, 0}, {1, 0}, {1, 4}}, 0.5, 0.1, 2.0);
  const auto legs = straight_legs(ref, ref);
  REQUIRE(legs.size() == 1);
  CHECK(legs[0].heading_deg == Approx(90.0));
}
