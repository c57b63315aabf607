// The `dsp` options section: defaults, every key read and checked, errors name file and key,
// and what print() writes reads back to the same options.
#include "rsrio/common/options.hpp"

#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_string.hpp>
#include <sstream>
#include <string>

#include "rsrio/dsp/dsp_options.hpp"
#include "scratch_dir.hpp"

using namespace rsrio;
using Catch::Matchers::ContainsSubstring;

namespace {

std::string write_yaml(const std::string& name, const std::string& body) {
  static const rsrio::testing::ScratchDir dir("dsp_options_test");
  return dir.write(name, "%YAML:1.0\n---\n" + body);
}

DspOptions load(const std::string& path) {
  OptionsFile f(path);
  OptionsNode root = f.root();
  std::string level;
  root.read("log_level", level);
  OptionsNode dsp = root.child("dsp");
  DspOptions o = load_dsp_options(dsp);
  root.finish();
  return o;
}

void expect_key_error(const std::string& body, const std::string& key, const std::string& what) {
  const std::string p = write_yaml("bad.yaml", body);
  try {
    (void)load(p);
    FAIL("no error for:\n" << body);
  } catch (const ConfigError& e) {
    INFO(e.what());
    CHECK(e.key() == key);
    CHECK(e.file() == p);
    CHECK_THAT(std::string(e.what()), ContainsSubstring(what));
  }
}

}  // namespace

TEST_CASE("dsp options: defaults without a section", "[dsp][options]") {
  const DspOptions o = load(write_yaml("empty.yaml", "log_level: info\n"));
  const DspOptions d;
  CHECK(o.range_window == d.range_window);
  CHECK(o.cfar.type == "ca");
  CHECK(o.cfar.pfa == d.cfar.pfa);
  CHECK(o.tdm_compensation);
}

TEST_CASE("dsp options: every key is read", "[dsp][options]") {
  const DspOptions o =
      load(write_yaml("all.yaml",
                      "dsp:\n"
                      "  range_window: blackman\n  doppler_window: hamming\n  angle_window: hann\n"
                      "  dc_removal: false\n  clutter_removal: true\n  tdm_compensation: false\n"
                      "  calibration: false\n  fft_planning: measure\n  interpolation: gaussian\n"
                      "  doppler_own_peak: true\n  max_angle_peaks: 4\n  angle_peak_db: 6.5\n"
                      "  cfar:\n    type: os\n    mode: dual_pass\n    pfa: 1.0e-6\n"
                      "    guard_range: 3\n    train_range: 10\n    guard_doppler: 2\n"
                      "    train_doppler: 6\n    os_rank: 0.6\n    discard_near_bins: 10\n"
                      "    discard_far_bins: 20\n    peak_grouping: false\n    max_detections: 99\n"));
  CHECK(o.range_window == "blackman");
  CHECK(o.doppler_window == "hamming");
  CHECK(o.angle_window == "hann");
  CHECK_FALSE(o.dc_removal);
  CHECK(o.clutter_removal);
  CHECK_FALSE(o.tdm_compensation);
  CHECK_FALSE(o.calibration);
  CHECK(o.fft_planning == "measure");
  CHECK(o.interpolation == "gaussian");
  CHECK(o.doppler_own_peak);
  CHECK(o.max_angle_peaks == 4);
  CHECK(o.angle_peak_db == 6.5);
  CHECK(o.cfar.type == "os");
  CHECK(o.cfar.mode == "dual_pass");
  CHECK(o.cfar.pfa == 1e-6);
  CHECK(o.cfar.guard_range == 3);
  CHECK(o.cfar.train_range == 10);
  CHECK(o.cfar.guard_doppler == 2);
  CHECK(o.cfar.train_doppler == 6);
  CHECK(o.cfar.os_rank == 0.6);
  CHECK(o.cfar.discard_near_bins == 10);
  CHECK(o.cfar.discard_far_bins == 20);
  CHECK_FALSE(o.cfar.peak_grouping);
  CHECK(o.cfar.max_detections == 99);

  // print() writes a section that loads back to the same values
  std::ostringstream s;
  print(s, o);
  const DspOptions back = load(write_yaml("printed.yaml", s.str()));
  std::ostringstream s2;
  print(s2, back);
  CHECK(s2.str() == s.str());

  // and so do the defaults: cfar.mode "2d" reads as a malformed number unless printed quoted
  std::ostringstream sd;
  print(sd, DspOptions{});
  CHECK(load(write_yaml("printed_defaults.yaml", sd.str())).cfar.mode == "2d");
}

TEST_CASE("dsp options: errors name the file and the key", "[dsp][options]") {
  expect_key_error("dsp:\n  range_window: kaiser\n", "dsp.range_window", "one of 'none' 'hann'");
  expect_key_error("dsp:\n  interpolation: parabolic\n", "dsp.interpolation", "one of 'calibrated' 'gaussian' 'none'");
  expect_key_error("dsp:\n  clutter_removal: maybe\n", "dsp.clutter_removal", "true or false");
  expect_key_error("dsp:\n  cfar:\n    pfa: 0.5\n", "dsp.cfar.pfa", "a number in");
  expect_key_error("dsp:\n  cfar:\n    type: go\n", "dsp.cfar.type", "one of 'ca' 'os'");
  expect_key_error("dsp:\n  cfar:\n    train_range: 2.5\n", "dsp.cfar.train_range", "an integer");
  expect_key_error("dsp:\n  cfar:\n    guard: 2\n", "dsp.cfar.guard", "no such key");
  expect_key_error("dsp:\n  angle_fft_size: 128\n", "dsp.angle_fft_size", "no such key");
  expect_key_error("dsp:\n  cfar: 3\n", "dsp.cfar", "a map");
}
