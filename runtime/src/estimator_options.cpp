#include "rsrio/runtime/estimator_options.hpp"

#include "rsrio/common/options.hpp"

namespace rsrio {

EstimatorOptions load_estimator_options(OptionsNode& root) {
  EstimatorOptions o;
  o.odometry = rio::load_odometry_options(root);
  if (root.has("backend")) o.backend = splat::load_backend_options(root.child("backend"));
  return o;
}

}  // namespace rsrio
