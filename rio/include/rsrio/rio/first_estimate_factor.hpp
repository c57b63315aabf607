// First-estimate Jacobians (Huang, Mourikis, Roumeliotis 2008; OpenVINS's FEJ) for the window's
// marginalisation. The marginal of a state that leaves the window is a linear prior on the next
// state, linearised at that state's estimate then. If the factors that still reach that state are
// relinearised at later estimates, the prior and they disagree about which directions (a turn about
// gravity, a shift) carry no information, and the window gains heading information that nothing
// measured: the whole window turns at once (rio/RESULTS.md, 2026-12-07). Evaluating their
// Jacobians at the same first estimate keeps the gauge free.
#pragma once

#include <gtsam/nonlinear/NonlinearFactor.h>
#include <gtsam/nonlinear/Values.h>

namespace rsrio::rio {

/// A factor whose Jacobians are taken with some of its variables held at their first estimates
/// (the others at today's values) and whose residual is today's: linearize() returns the wrapped
/// factor's Jacobian blocks at the first estimates with its right-hand side at today's values;
/// error() is the wrapped factor's. The wrapped factor must linearise to a JacobianFactor (every
/// NoiseModelFactor does); otherwise today's linearisation is returned unchanged.
class FirstEstimateFactor : public gtsam::NonlinearFactor {
 public:
  /// first: values of some of factor's keys (keys it does not have are ignored).
  FirstEstimateFactor(gtsam::NonlinearFactor::shared_ptr factor, const gtsam::Values& first);

  double error(const gtsam::Values& values) const override { return factor_->error(values); }
  std::size_t dim() const override { return factor_->dim(); }
  boost::shared_ptr<gtsam::GaussianFactor> linearize(const gtsam::Values& values) const override;
  gtsam::NonlinearFactor::shared_ptr clone() const override {
    return boost::make_shared<FirstEstimateFactor>(*this);
  }

  const gtsam::NonlinearFactor::shared_ptr& wrapped() const { return factor_; }
  const gtsam::Values& first_estimates() const { return first_; }

 private:
  gtsam::NonlinearFactor::shared_ptr factor_;
  gtsam::Values first_;
};

}  // namespace rsrio::rio
