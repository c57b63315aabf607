// CFAR: the analytic threshold design matches the textbook closed forms; on target-free complex
// Gaussian noise through the whole chain the false-alarm rate is the design value (within a
// factor of 2); targets well above the noise are detected.
#include "rsrio/dsp/cfar.hpp"

#include <catch2/catch_test_macros.hpp>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "dsp_test_support.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/dsp/processor.hpp"

using namespace rsrio;

TEST_CASE("CFAR design: special functions", "[cfar][design]") {
  // P(1, x) = 1 - exp(-x); P(a, x) + Q(a, x) = 1; I_x(1, b) = 1 - (1 - x)^b.
  CHECK(std::fabs(cfar::gamma_p(1, 2.0) - (1 - std::exp(-2.0))) < 1e-12);
  CHECK(std::fabs(cfar::gamma_p(7.5, 5.0) + cfar::gamma_q(7.5, 5.0) - 1) < 1e-12);
  // Q(3, x) = exp(-x) (1 + x + x^2 / 2): deep tail computed directly
  const double x = 60;
  CHECK(std::fabs(cfar::gamma_q(3, x) / (std::exp(-x) * (1 + x + x * x / 2)) - 1) < 1e-9);
  CHECK(std::fabs(cfar::beta_i(1, 5, 0.2) - (1 - std::pow(0.8, 5))) < 1e-12);
  CHECK(std::fabs(cfar::beta_i_upper(1, 5, 0.9) - std::pow(0.1, 5)) < 1e-15);
}

TEST_CASE("CFAR design: CA with one channel is the textbook (1 + alpha / N)^-N", "[cfar][design]") {
  for (int n : {8, 16, 32})
    for (double pfa : {1e-2, 1e-4, 1e-6}) {
      const double alpha = cfar::ca_alpha(pfa, n, 1.0);
      const double closed = n * (std::pow(pfa, -1.0 / n) - 1);
      INFO("N " << n << " pfa " << pfa);
      CHECK(std::fabs(alpha / closed - 1) < 1e-6);
      CHECK(std::fabs(cfar::ca_pfa(alpha, n, 1.0) / pfa - 1) < 1e-6);
    }
}

TEST_CASE("CFAR design: OS with one channel is Rohling's product", "[cfar][design]") {
  for (int n : {16, 24})
    for (double alpha : {5.0, 15.0}) {
      const int k = cfar::os_k(0.75, n);
      double closed = 1;
      for (int i = 0; i < k; ++i) closed *= (n - i) / (n - i + alpha);
      INFO("N " << n << " k " << k << " alpha " << alpha);
      CHECK(std::fabs(cfar::os_pfa(alpha, n, k, 1.0) / closed - 1) < 1e-4);
    }
  // and the design inverts it
  const double a = cfar::os_alpha(1e-4, 16, 12, 1.0);
  CHECK(std::fabs(cfar::os_pfa(a, 16, 12, 1.0) / 1e-4 - 1) < 1e-3);
}

TEST_CASE("CFAR design: many training cells tend to the Gamma quantile of the CUT", "[cfar][design]") {
  // With N -> infinity the noise estimate is exact: Pfa = Q(V, alpha V).
  const double V = 12, pfa = 1e-3;
  const double alpha = cfar::ca_alpha(pfa, 100000, V);
  CHECK(std::fabs(cfar::gamma_q(V, alpha * V) / pfa - 1) < 0.02);
  // Fewer cells need a higher threshold for the same Pfa.
  CHECK(cfar::ca_alpha(pfa, 16, V) > cfar::ca_alpha(pfa, 200, V));
  // OS mean ratio: the 75 % order statistic of exponentials is above the mean.
  CHECK(cfar::os_mean_ratio(16, 12, 1.0) > 1.1);
}

namespace {

struct FaResult {
  double rate = 0;
  std::size_t alarms = 0, cells = 0;
};

FaResult false_alarm_rate(const std::string& type, const std::string& mode, double pfa, int frames,
                          const std::string& preset = "xwr1843") {
  const RadarConfig c = radar_preset(preset);
  DspOptions o;
  o.cfar.type = type;
  o.cfar.mode = mode;
  o.cfar.pfa = pfa;
  o.cfar.peak_grouping = false;  // the design Pfa is per cell
  DspProcessor dsp(c, o);
  FaResult r;
  for (int f = 0; f < frames; ++f) {
    const DspResult& res = dsp.process(rsrio::test::synthesize(c, {}, 100.0, 1000 + f));
    r.alarms += res.detections.size();
    r.cells += res.cells_tested;
  }
  r.rate = static_cast<double>(r.alarms) / r.cells;
  std::printf("CFAR %s %s %s: design Pfa %.1e, measured %.3e (%zu alarms in %zu cells, %d frames)\n",
              preset.c_str(), type.c_str(), mode.c_str(), pfa, r.rate, r.alarms, r.cells, frames);
  return r;
}

}  // namespace

TEST_CASE("CFAR false-alarm rate on complex Gaussian noise matches the design", "[cfar][pfa]") {
  const double pfa = 1e-3;
  // xwr1843: 248 tested range bins x 64 Doppler bins per frame; 6 frames -> ~95 expected alarms.
  SECTION("CA 2-D") {
    const FaResult r = false_alarm_rate("ca", "2d", pfa, 6);
    CHECK(r.rate > pfa / 2);
    CHECK(r.rate < pfa * 2);
  }
  SECTION("OS 2-D") {
    const FaResult r = false_alarm_rate("os", "2d", pfa, 6);
    CHECK(r.rate > pfa / 2);
    CHECK(r.rate < pfa * 2);
  }
  SECTION("mmwcas: 192 channels (Gamma shape 192), CA and OS 2-D") {
    // 120 tested range bins x 32 Doppler bins per frame: a higher Pfa for enough counts
    for (const std::string type : {"ca", "os"}) {
      const FaResult r = false_alarm_rate(type, "2d", 1e-2, 4, "mmwcas");
      CHECK(r.rate > 1e-2 / 2);
      CHECK(r.rate < 1e-2 * 2);
    }
  }
  SECTION("dual pass: the AND of two passes each designed for Pfa stays below it") {
    const FaResult ca = false_alarm_rate("ca", "dual_pass", pfa, 6);
    CHECK(ca.rate < pfa * 2);
    CHECK(ca.alarms > 0);
    const FaResult os = false_alarm_rate("os", "dual_pass", pfa, 6);
    CHECK(os.rate < pfa * 2);
    CHECK(os.alarms > 0);
  }
}

TEST_CASE("CFAR detects targets above the noise and nothing far from them", "[cfar]") {
  const RadarConfig c = radar_preset("xwr1843");
  const RadarDerived d = derive(c);
  for (const std::string type : {"ca", "os"})
    for (const std::string mode : {"2d", "dual_pass"}) {
      DspOptions o;
      o.cfar.type = type;
      o.cfar.mode = mode;
      o.cfar.pfa = 1e-6;
      DspProcessor dsp(c, o);
      // amplitude 2 in noise of power 100 per sample: about 26 dB after the 256 x 64 x 8 gain
      const std::vector<rsrio::test::PointTarget> targets = {{5.0, 1.0, 10.0, 0, 2.0},
                                                             {15.0, -2.0, -30.0, 0, 2.0}};
      const DspResult& res = dsp.process(rsrio::test::synthesize(c, targets, 100.0, 77));
      INFO(type << " " << mode << ": " << res.detections.size() << " detections");
      for (const auto& t : targets) {
        bool found = false;
        for (const auto& det : res.detections) {
          const double r = det.range_bin * d.range_bin_size_m;
          const double v = (det.doppler_bin - 32) * d.velocity_bin_size_mps;
          if (std::fabs(r - t.range_m) < 2 * d.range_bin_size_m &&
              std::fabs(v - t.velocity_mps) < 2 * d.velocity_bin_size_mps)
            found = true;
        }
        CHECK(found);
      }
      CHECK(res.detections.size() <= 4);  // peak grouping: one per target (plus rare noise)
    }
}

TEST_CASE("a CFAR window wider than the Doppler axis is a configuration error naming the key", "[cfar]") {
  RadarConfig c = radar_preset("xwr1843");
  c.loops = 8;
  DspOptions o;
  o.cfar.train_doppler = 6;
  try {
    DspProcessor dsp(c, o);
    FAIL("no error");
  } catch (const ConfigError& e) {
    CHECK(e.key() == "dsp.cfar.train_doppler");
  }
}
