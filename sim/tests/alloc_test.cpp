// RadarSimulator::simulate() allocates nothing once the simulator is built: a counting global
// operator new sees no call while frames are made (people, ghosts and all, on two threads).
#include <catch2/catch_test_macros.hpp>

#include "counting_allocator.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"

TEST_CASE("sim: making a radar frame allocates nothing", "[alloc]") {
  rsrio::sim::Scenario s = rsrio::sim::load_scenario("scenarios/test_tiny.yaml");
  s.radar_model.channel_phase_error_deg = 3.0;
  rsrio::sim::Simulation sim(s, 2);
  rsrio::AdcCube cube;
  sim.radar().simulate(0, cube);  // sizes the cube
  {
    // The counter sees this executable's allocations (else "nothing" below would prove nothing).
    const long before = rsrio::testing::allocation_count();
    rsrio::testing::allocate_once();
    REQUIRE(rsrio::testing::allocation_count() - before == 1);
  }
  const long before = rsrio::testing::allocation_count();
  std::size_t visible = 0;
  for (std::uint64_t k = 1; k < 20; ++k) visible += sim.radar().simulate(k, cube).visible_scatterers;
  CHECK(rsrio::testing::allocation_count() - before == 0);
  CHECK(visible > 0);
}
