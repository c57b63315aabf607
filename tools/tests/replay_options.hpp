// Options files read as rsrio-replay reads its --config file: rsrio::load_program_config's
// log_level (not called itself: it registers a logger, once a process) and the estimator's
// sections, strictly. For the tests of the options files that rsrio-eval makes and that ship.
#pragma once

#include <fstream>
#include <sstream>
#include <string>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/common/options.hpp"
#include "rsrio/runtime/estimator_options.hpp"

namespace rsrio::testing {

inline EstimatorOptions load_as_replay(const std::string& path) {
  OptionsFile file(path);
  OptionsNode root = file.root();
  std::string level = "info";
  root.read_choice("log_level", level, {"trace", "debug", "info", "warn", "error", "critical", "off"});
  EstimatorOptions options = load_estimator_options(root);
  root.finish();
  return options;
}

/// A file's text (relative paths: from the repository root, where the tests run).
inline std::string file_text(const std::string& path) {
  std::ifstream f(path);
  REQUIRE(f.good());
  std::stringstream text;
  text << f.rdbuf();
  return text.str();
}

}  // namespace rsrio::testing
