// Same seed -> the same bytes, with any number of threads; another seed -> other noise.
#include <cstdint>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"

using namespace rsrio::sim;

namespace {

std::vector<std::uint8_t> frame_bytes(const Scenario& scenario, int threads, std::uint64_t frame) {
  Simulation sim(scenario, threads);
  rsrio::AdcCube cube;
  sim.radar().simulate(frame, cube);
  std::vector<std::uint8_t> bytes;
  rsrio::encode_frame(sim.radar().config(), cube, bytes);
  return bytes;
}

}  // namespace

TEST_CASE("sim: frames are identical for a seed whatever the thread count", "[determinism]") {
  const Scenario s = load_scenario("scenarios/test_tiny.yaml");
  const auto one = frame_bytes(s, 1, 5);
  REQUIRE(one.size() == rsrio::raw_frame_bytes(s.radar));
  CHECK(frame_bytes(s, 2, 5) == one);
  CHECK(frame_bytes(s, 3, 5) == one);
  CHECK(frame_bytes(s, 1, 5) == one);  // a fresh simulation of the same seed
}

TEST_CASE("sim: another seed gives other noise on the same scene", "[determinism]") {
  Scenario s = load_scenario("scenarios/test_tiny.yaml");
  const auto a = frame_bytes(s, 2, 3);
  s.seed = 8;
  const auto b = frame_bytes(s, 2, 3);
  REQUIRE(a.size() == b.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
  CHECK(differ > a.size() / 4);
  // Without thermal noise the seed only moves the leakage phases: switch both off, and the two
  // seeds give the same frame.
  s.radar_model.thermal_noise = false;
  s.radar_model.leakage_amplitude_lsb = 0;
  const auto c = frame_bytes(s, 2, 3);
  s.seed = 7;
  CHECK(frame_bytes(s, 2, 3) == c);
}

TEST_CASE("sim: consecutive frames of a simulation are reproducible in any order", "[determinism]") {
  const Scenario s = load_scenario("scenarios/test_tiny.yaml");
  Simulation sim(s, 2);
  rsrio::AdcCube cube;
  std::vector<std::uint8_t> first, again;
  sim.radar().simulate(4, cube);
  rsrio::encode_frame(s.radar, cube, first);
  sim.radar().simulate(9, cube);
  sim.radar().simulate(4, cube);
  rsrio::encode_frame(s.radar, cube, again);
  CHECK(first == again);
}
