// Ego-velocity: the sign convention, exact recovery, robustness to movers, honest covariance,
// refusal on degenerate geometry.
#include "rsrio/rio/ego_velocity.hpp"

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/LU>
#include <catch2/catch_approx.hpp>
#include <catch2/catch_test_macros.hpp>

using Catch::Approx;
using rsrio::rio::DopplerMeasurement;
using rsrio::rio::EgoVelocityEstimator;

namespace {

Eigen::Vector3d direction(double az_deg, double el_deg) {
  const double a = az_deg * M_PI / 180, e = el_deg * M_PI / 180;
  return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

// Static points in a +-60 deg azimuth, +-15 deg elevation field of view, seen from velocity v.
std::vector<DopplerMeasurement> static_scene(const Eigen::Vector3d& v, int n, double noise, std::mt19937& rng) {
  std::uniform_real_distribution<double> az(-60, 60), el(-15, 15);
  std::normal_distribution<double> nz(0, noise);
  std::vector<DopplerMeasurement> pts;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d r = direction(az(rng), el(rng));
    pts.push_back({r, -r.dot(v) + nz(rng)});
  }
  return pts;
}

}  // namespace

TEST_CASE("sign: driving towards a wall ahead gives negative Doppler and forward velocity", "[ego_velocity]") {
  // A radar moving forward at 1 m/s: every static point ahead approaches (range shrinks), so its
  // Doppler is negative under the receding-positive convention.
  std::vector<DopplerMeasurement> pts;
  for (double az : {-30.0, -15.0, 0.0, 10.0, 20.0, 35.0})
    for (double el : {-10.0, 0.0, 10.0}) {
      const Eigen::Vector3d r = direction(az, el);
      pts.push_back({r, -r.x() * 1.0});
    }
  CHECK(pts[2].doppler_mps < 0);
  EgoVelocityEstimator est;
  const auto v = est.estimate(pts);
  REQUIRE(v.ok());
  CHECK(v.velocity.x() == Approx(1.0).margin(1e-9));
  CHECK(v.velocity.y() == Approx(0.0).margin(1e-9));
  CHECK(v.velocity.z() == Approx(0.0).margin(1e-9));
}

TEST_CASE("recovers the velocity within its stated covariance, with 30 % movers", "[ego_velocity]") {
  std::mt19937 rng(3);
  const Eigen::Vector3d truth(1.1, -0.3, 0.05);
  auto pts = static_scene(truth, 140, 0.03, rng);
  // Movers: people walking at 1-2 m/s in random directions, 30 % of the detections.
  std::uniform_real_distribution<double> az(-60, 60), speed(-2, 2);
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector3d r = direction(az(rng), 0);
    pts.push_back({r, -r.dot(truth) + speed(rng) + (speed(rng) > 0 ? 0.5 : -0.5)});
  }
  EgoVelocityEstimator est;
  const auto v = est.estimate(pts, 17);
  REQUIRE(v.ok());
  const Eigen::Vector3d err = v.velocity - truth;
  // Mahalanobis distance of the error under the stated covariance: chi-square(3), 99.9 % < 16.3
  CHECK(err.dot(v.covariance.inverse() * err) < 16.3);
  CHECK(err.head<2>().norm() < 0.03);
  CHECK(v.inliers >= 135);
  CHECK(v.inliers <= 150);
}

TEST_CASE("the stated covariance matches the scatter over many frames", "[ego_velocity]") {
  std::mt19937 rng(11);
  const Eigen::Vector3d truth(0.8, 0.2, 0.0);
  EgoVelocityEstimator est;
  double mahalanobis = 0;
  const int frames = 300;
  for (int f = 0; f < frames; ++f) {
    const auto v = est.estimate(static_scene(truth, 60, 0.05, rng), f);
    REQUIRE(v.ok());
    const Eigen::Vector3d e = v.velocity - truth;
    mahalanobis += e.dot(v.covariance.inverse() * e);
  }
  // Mean of chi-square(3) is 3; allow for the inlier cut and sampling.
  CHECK(mahalanobis / frames == Approx(3.0).epsilon(0.25));
}

TEST_CASE("planar mode estimates x and y only", "[ego_velocity]") {
  rsrio::rio::EgoVelocityOptions o;
  o.dimensions = 2;
  std::vector<DopplerMeasurement> pts;
  for (double az = -50; az <= 50; az += 10) {
    const Eigen::Vector3d r = direction(az, 0);
    pts.push_back({r, -(r.x() * 0.5 + r.y() * 0.4)});
  }
  const auto v = EgoVelocityEstimator(o).estimate(pts);
  REQUIRE(v.ok());
  CHECK(v.velocity.x() == Approx(0.5));
  CHECK(v.velocity.y() == Approx(0.4));
  CHECK(v.velocity.z() == 0.0);
}

TEST_CASE("too few points and degenerate geometry are refused, not guessed", "[ego_velocity]") {
  EgoVelocityEstimator est;
  std::vector<DopplerMeasurement> few(4, {direction(0, 0), -1.0});
  CHECK(est.estimate(few).status == rsrio::rio::EgoVelocityStatus::kTooFewPoints);
  // Twenty points within half a degree of one direction: only the velocity along it is observable.
  std::vector<DopplerMeasurement> line;
  for (int i = 0; i < 20; ++i) line.push_back({direction(10 + 0.025 * i, 0.02 * (i % 3)), -0.7});
  const auto v = est.estimate(line);
  CHECK(v.status == rsrio::rio::EgoVelocityStatus::kDegenerate);
  // A scene that is mostly moving: no consensus.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> az(-60, 60), dop(-2, 2);
  std::vector<DopplerMeasurement> chaos;
  for (int i = 0; i < 40; ++i) chaos.push_back({direction(az(rng), 0), dop(rng)});
  CHECK_FALSE(est.estimate(chaos).ok());
}
