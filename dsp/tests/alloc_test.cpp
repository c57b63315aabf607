// process() allocates nothing: a counting global operator new sees no call while frames go
// through a constructed processor, for every CFAR variant and both presets.
#include <atomic>
#include <catch2/catch_test_macros.hpp>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include "dsp_test_support.hpp"
#include "rsrio/dsp/processor.hpp"

namespace {
std::atomic<long> g_allocations{0};
}

// The replacements pair malloc with free; GCC cannot see that operator new here is ours.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
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
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
#pragma GCC diagnostic pop

using namespace rsrio;

TEST_CASE("the counting allocator counts", "[dsp][alloc]") {
  const long before = g_allocations.load();
  auto* v = new std::vector<int>(100);
  delete v;
  CHECK(g_allocations.load() - before >= 2);
}

TEST_CASE("process() does not allocate", "[dsp][alloc]") {
  for (const std::string preset : {"xwr1843", "mmwcas"}) {
    const RadarConfig c = radar_preset(preset);
    const RadarDerived d = derive(c);
    std::vector<AdcCube> frames;
    for (std::uint32_t s = 0; s < 2; ++s)
      frames.push_back(rsrio::test::synthesize(
          c, {{3.0, 0.5, 10.0, 5.0}, {7.0, -d.max_velocity_mps * 0.9, -40.0}, {9.0, 0.0, 0.0}}, 100.0, s));
    for (const std::string type : {"ca", "os"})
      for (const std::string mode : {"2d", "dual_pass"}) {
        DspOptions o;
        o.cfar.type = type;
        o.cfar.mode = mode;
        o.cfar.pfa = 1e-2;           // many detections: the lists fill up
        o.cfar.max_detections = 50;  // and overflow: the strongest are kept in place
        o.max_angle_peaks = 3;
        o.clutter_removal = true;
        DspProcessor dsp(c, o);
        const long before = g_allocations.load();
        std::size_t points = 0, dets = 0;
        for (int rep = 0; rep < 2; ++rep)
          for (const auto& f : frames) {
            const DspResult& r = dsp.process(f);
            points += r.points.size();
            dets += r.detections.size();
          }
        const long during = g_allocations.load() - before;
        INFO(preset << " " << type << " " << mode << ": " << dets << " detections, " << points << " points");
        CHECK(during == 0);
        CHECK(dets > 0);
        CHECK(points >= dets);
      }
  }
}
