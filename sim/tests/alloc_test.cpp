// RadarSimulator::simulate() allocates nothing once the simulator is built: a counting global
// operator new sees no call while frames are made (people, ghosts and all, on two threads).
#include <atomic>
#include <cstdlib>
#include <new>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"

namespace {
std::atomic<long> g_allocations{0};
}

void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, std::align_val_t a) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

TEST_CASE("sim: making a radar frame allocates nothing", "[alloc]") {
  rsrio::sim::Scenario s = rsrio::sim::load_scenario("scenarios/test_tiny.yaml");
  s.radar_model.channel_phase_error_deg = 3.0;
  rsrio::sim::Simulation sim(s, 2);
  rsrio::AdcCube cube;
  sim.radar().simulate(0, cube);  // sizes the cube
  const long before = g_allocations.load();
  std::size_t visible = 0;
  for (std::uint64_t k = 1; k < 20; ++k) visible += sim.radar().simulate(k, cube).visible_scatterers;
  CHECK(g_allocations.load() - before == 0);
  CHECK(visible > 0);
}
