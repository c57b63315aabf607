// process() allocates nothing: a counting global operator new sees no call while frames go
// through a constructed processor, for every CFAR variant and both presets.
#include <catch2/catch_test_macros.hpp>
#include <string>
#include <vector>

#include "dsp_test_support.hpp"
#include "counting_allocator.hpp"
#include "rsrio/dsp/processor.hpp"

using namespace rsrio;

TEST_CASE("the counting allocator counts", "[dsp][alloc]") {
  const long before = rsrio::testing::allocation_count();
  rsrio::testing::allocate_once();
  CHECK(rsrio::testing::allocation_count() - before == 1);
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
        const long before = rsrio::testing::allocation_count();
        std::size_t points = 0, dets = 0;
        for (int rep = 0; rep < 2; ++rep)
          for (const auto& f : frames) {
            const DspResult& r = dsp.process(f);
            points += r.points.size();
            dets += r.detections.size();
          }
        const long during = rsrio::testing::allocation_count() - before;
        INFO(preset << " " << type << " " << mode << ": " << dets << " detections, " << points << " points");
        CHECK(during == 0);
        CHECK(dets > 0);
        CHECK(points >= dets);
      }
  }
}
