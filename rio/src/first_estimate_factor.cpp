#include "rsrio/rio/first_estimate_factor.hpp"

#include <utility>

#include <gtsam/linear/JacobianFactor.h>

namespace rsrio::rio {

FirstEstimateFactor::FirstEstimateFactor(gtsam::NonlinearFactor::shared_ptr factor, const gtsam::Values& first)
    : gtsam::NonlinearFactor(factor->keys()), factor_(std::move(factor)) {
  for (gtsam::Key key : factor_->keys())
    if (first.exists(key)) first_.insert(key, first.at(key));
}

boost::shared_ptr<gtsam::GaussianFactor> FirstEstimateFactor::linearize(const gtsam::Values& values) const {
  const auto today = factor_->linearize(values);
  if (first_.empty()) return today;
  gtsam::Values at_first;  // the factor's own variables only
  for (gtsam::Key key : keys()) at_first.insert(key, first_.exists(key) ? first_.at(key) : values.at(key));
  const auto jacobians = boost::dynamic_pointer_cast<gtsam::JacobianFactor>(factor_->linearize(at_first));
  const auto residual = boost::dynamic_pointer_cast<gtsam::JacobianFactor>(today);
  if (!jacobians || !residual) return today;
  // The wrapped factor's Jacobian blocks at the first estimates, its right-hand side today's.
  jacobians->getb() = residual->getb();
  return jacobians;
}

}  // namespace rsrio::rio
