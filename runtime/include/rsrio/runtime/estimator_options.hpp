// The estimator's sections of a pipeline options file, read once for every program that runs the
// pipeline (rsriod, rsrio-replay) and for the tests that check an options file as they would.
#pragma once

#include "rsrio/rio/odometry.hpp"
#include "rsrio/splat/backend.hpp"

namespace rsrio {

class OptionsNode;

struct EstimatorOptions {
  rio::OdometryOptions odometry;  // dsp:, ego_velocity:, frontend:
  splat::BackendOptions backend;  // backend: (its defaults when the section is absent)
};

/// Reads those sections from the file's root, strictly (a bad or unknown key throws ConfigError
/// naming it); the caller's root.finish() then refuses what no section read.
EstimatorOptions load_estimator_options(OptionsNode& root);

}  // namespace rsrio
