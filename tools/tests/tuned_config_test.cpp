// config/rsrio-tuned.yaml, the options the README's tuned Table II row replays with: it loads as
// rsrio-replay loads it, and differs from config/rsrio.yaml in exactly the keys its header names
// (a key changed in one file and not the other would make the README's figures those of another
// configuration).
#include <catch2/catch_test_macros.hpp>

#include <set>
#include <sstream>
#include <string>

#include "replay_options.hpp"

namespace {

// The keys whose printed lines (rio::print, splat::print: one line a key) differ between a and b.
std::set<std::string> differing_keys(const rsrio::EstimatorOptions& a, const rsrio::EstimatorOptions& b) {
  auto lines = [](const rsrio::EstimatorOptions& o) {
    std::ostringstream s;
    rsrio::rio::print(s, o.odometry);
    rsrio::splat::print(s, o.backend);
    std::multiset<std::string> out;
    std::istringstream in(s.str());
    for (std::string line; std::getline(in, line);) out.insert(line);
    return out;
  };
  const std::multiset<std::string> la = lines(a), lb = lines(b);
  std::set<std::string> keys;
  auto add = [&](const std::multiset<std::string>& from, const std::multiset<std::string>& other) {
    for (const std::string& line : from) {
      if (other.count(line) == from.count(line)) continue;
      const std::size_t first = line.find_first_not_of(' ');
      if (first == std::string::npos) continue;  // a blank line is no key
      keys.insert(line.substr(first, line.find(':') - first));
    }
  };
  add(la, lb);
  add(lb, la);
  return keys;
}

}  // namespace

TEST_CASE("config/rsrio-tuned.yaml: the shipped options with the tuned keys changed, and nothing else",
          "[eval][config]") {
  const rsrio::EstimatorOptions shipped = rsrio::testing::load_as_replay("config/rsrio.yaml");
  const rsrio::EstimatorOptions tuned = rsrio::testing::load_as_replay("config/rsrio-tuned.yaml");
  const std::set<std::string> expected{"drop_ambiguous_azimuth", "position_from_velocity",   "pose_dof",
                                       "rd_loss",                "final_ba",                 "ba_window",
                                       "odometry_yaw_sigma_deg", "odometry_prior_sigma_deg", "loop_graph",
                                       "loop_image_alignment",   "loop_match",               "heading_drift_window_s"};
  CHECK(differing_keys(shipped, tuned) == expected);
  CHECK(tuned.odometry.points.drop_ambiguous_azimuth);
  CHECK(tuned.odometry.frontend.position_from_velocity);
  CHECK(tuned.backend.pose_dof == 6);
  CHECK_FALSE(tuned.backend.rd_loss);
  CHECK(tuned.backend.final_ba.max_iterations == 100);
  CHECK(tuned.backend.ba_window == "sliding");
  CHECK(tuned.backend.ba_sliding_keyframes == 10);
  CHECK(tuned.backend.odometry_yaw_sigma_deg == 0);
  CHECK(tuned.backend.odometry_prior_sigma_deg == 0.3);
  CHECK(tuned.backend.loop_graph.odometry_sigma_deg == 0.05);
  CHECK(tuned.backend.loop_image_alignment);
  CHECK_FALSE(tuned.backend.loop.refine_peak);
  CHECK(tuned.backend.heading_drift_window_s == 0);
  // The comparison itself sees a change.
  rsrio::EstimatorOptions moved = tuned;
  moved.backend.loop_graph.loop_sigma_m *= 2;
  CHECK(differing_keys(tuned, moved) == std::set<std::string>{"loop_graph"});
}
