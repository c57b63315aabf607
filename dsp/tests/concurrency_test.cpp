// Processors made and run on several threads at once: plan creation and destruction go through
// the FFTW planner lock, and results do not depend on what the other threads do.
#include <catch2/catch_test_macros.hpp>
#include <thread>
#include <vector>

#include "dsp_test_support.hpp"
#include "rsrio/dsp/fftw.hpp"
#include "rsrio/dsp/processor.hpp"

using namespace rsrio;

TEST_CASE("processors on parallel threads give the single-thread results", "[dsp][concurrency]") {
  RadarConfig c = radar_preset("xwr1843");
  c.loops = 16;
  const AdcCube cube = rsrio::test::synthesize(c, {{4.0, 0.5, 10.0}, {9.0, -1.0, -30.0}}, 10.0, 3);
  std::vector<float> expected;
  {
    DspProcessor dsp(c);
    const DspResult& r = dsp.process(cube);
    expected.assign(r.rd.begin(), r.rd.end());
  }
  constexpr int kThreads = 4;
  std::vector<int> same(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (int rep = 0; rep < 3; ++rep) {  // plans made and destroyed concurrently
        DspOptions o;
        o.cfar.type = (t % 2) ? "os" : "ca";
        DspProcessor dsp(c, o);
        const DspResult& r = dsp.process(cube);
        same[t] += std::equal(r.rd.begin(), r.rd.end(), expected.begin(), expected.end()) ? 1 : 0;
      }
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) CHECK(same[t] == 3);
  CHECK(fftw_planner_made_thread_safe());
}
