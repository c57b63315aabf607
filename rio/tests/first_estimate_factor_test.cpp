// FirstEstimateFactor: the wrapped factor's Jacobians at the first estimates, its residual today's.
#include "rsrio/rio/first_estimate_factor.hpp"

#include <catch2/catch_test_macros.hpp>
#include <gtsam/geometry/Pose3.h>
#include <gtsam/inference/Symbol.h>
#include <gtsam/linear/JacobianFactor.h>
#include <gtsam/slam/BetweenFactor.h>

using rsrio::rio::FirstEstimateFactor;
using gtsam::symbol_shorthand::X;

namespace {

gtsam::JacobianFactor::shared_ptr jacobian(const gtsam::NonlinearFactor& f, const gtsam::Values& at) {
  auto j = boost::dynamic_pointer_cast<gtsam::JacobianFactor>(f.linearize(at));
  REQUIRE(j);
  return j;
}

}  // namespace

TEST_CASE("FirstEstimateFactor: Jacobians at the first estimates, residual and error at today's values",
          "[first_estimate_factor]") {
  const gtsam::Pose3 measured(gtsam::Rot3::Ypr(0.3, -0.1, 0.05), gtsam::Point3(1.0, 0.2, -0.1));
  const auto between = boost::make_shared<gtsam::BetweenFactor<gtsam::Pose3>>(
      X(0), X(1), measured, gtsam::noiseModel::Isotropic::Sigma(6, 0.1));
  gtsam::Values today;
  today.insert(X(0), gtsam::Pose3(gtsam::Rot3::Ypr(0.5, 0.02, -0.03), gtsam::Point3(2, -1, 0.3)));
  today.insert(X(1), gtsam::Pose3(gtsam::Rot3::Ypr(0.9, -0.05, 0.01), gtsam::Point3(3.1, -0.5, 0.2)));
  gtsam::Values first;  // X(1) as it was first estimated, and a key the factor does not have
  first.insert(X(1), gtsam::Pose3(gtsam::Rot3::Ypr(0.7, -0.08, 0.04), gtsam::Point3(2.8, -0.7, 0.25)));
  first.insert(X(7), gtsam::Pose3());
  const FirstEstimateFactor fej(between, first);
  REQUIRE(fej.first_estimates().size() == 1);

  CHECK(fej.error(today) == between->error(today));
  gtsam::Values at_first = today;
  at_first.update(X(1), first.at(X(1)));
  const auto expected_a = jacobian(*between, at_first), expected_b = jacobian(*between, today);
  const auto got = jacobian(fej, today);
  REQUIRE(got->keys() == expected_a->keys());
  for (std::size_t i = 0; i < got->size(); ++i)
    CHECK(gtsam::assert_equal(gtsam::Matrix(expected_a->getA(expected_a->begin() + i)),
                              gtsam::Matrix(got->getA(got->begin() + i)), 1e-12));
  CHECK(gtsam::assert_equal(gtsam::Vector(expected_b->getb()), gtsam::Vector(got->getb()), 1e-12));
  // The Jacobians do depend on where they are taken (X(0)'s block on X(1): -Ad of the relative
  // pose's inverse; X(1)'s is the identity in GTSAM's tangents): the first estimate is not today's.
  CHECK((expected_b->getA(expected_b->begin()) - got->getA(got->begin())).norm() > 1e-3);
  // At the first estimates the wrapper is the factor.
  const auto same = jacobian(fej, at_first);
  CHECK(same->equals(*jacobian(*between, at_first), 1e-12));
  // With no first estimate of any of its keys it is the factor.
  const FirstEstimateFactor none(between, gtsam::Values());
  CHECK(jacobian(none, today)->equals(*expected_b, 1e-12));
}
