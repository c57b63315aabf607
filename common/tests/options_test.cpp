// Options files: every kind of bad file gets one error naming file and key; a good file loads.
#include "rsrio/common/options.hpp"

#include <cstdio>
#include <filesystem>
#include <string>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/common/radar_config.hpp"
#include "scratch_dir.hpp"

namespace {

// One options file with this text, in the process's scratch directory.
struct TempFile {
  std::filesystem::path path;
  explicit TempFile(const std::string& text) {
    static const rsrio::testing::ScratchDir dir("options_test");
    static int n = 0;
    path = dir.write("options_" + std::to_string(n++) + ".yaml", text);
  }
};

rsrio::RadarConfig load(const std::string& path) {
  rsrio::OptionsFile file(path);
  auto root = file.root();
  auto radar = root.child("radar", true);
  auto c = rsrio::load_radar_config(radar);
  root.finish();
  return c;
}

std::string error_key(const std::string& text) {
  TempFile f(text);
  try {
    load(f.path.string());
  } catch (const rsrio::ConfigError& e) {
    CHECK(e.file() == f.path.string());
    CHECK(std::string(e.what()).find(f.path.string()) != std::string::npos);
    return e.key();
  }
  FAIL("no ConfigError for:\n" << text);
  return {};
}

}  // namespace

TEST_CASE("a good file overrides the preset", "[options]") {
  TempFile f("%YAML:1.0\n---\nradar:\n  preset: mmwcas\n  loops: 64\n  chirp:\n    idle_time_us: 5.0\n"
             "  capture:\n    iq_order: q_first\n    offset_binary: true\n");
  const auto c = load(f.path.string());
  CHECK(c.preset == "mmwcas");
  CHECK(c.loops == 64);
  CHECK(c.chirp.idle_time_us == 5.0);
  CHECK(c.chirp.samples_per_chirp == 128);  // from the preset
  CHECK(c.capture.iq_order == "q_first");
  CHECK(c.capture.offset_binary);
}

TEST_CASE("YAML without the OpenCV directive is read too", "[options]") {
  TempFile f("radar:\n  preset: xwr1843\n  frame_period_ms: 50\n");
  CHECK(load(f.path.string()).frame_period_ms == 50.0);
}

TEST_CASE("unknown key is named", "[options]") {
  CHECK(error_key("radar:\n  preset: xwr1843\n  chirp:\n    slope_mhz_per_uss: 30\n") == "radar.chirp.slope_mhz_per_uss");
  CHECK(error_key("radar:\n  preset: xwr1843\nradr: 1\n") == "radr");
}

TEST_CASE("wrong type is named", "[options]") {
  CHECK(error_key("radar:\n  preset: xwr1843\n  loops: many\n") == "radar.loops");
  CHECK(error_key("radar:\n  preset: xwr1843\n  loops: 3.5\n") == "radar.loops");
  CHECK(error_key("radar:\n  preset: xwr1843\n  tx_order: 1\n") == "radar.tx_order");
  CHECK(error_key("radar:\n  preset: xwr1843\n  capture:\n    offset_binary: maybe\n") == "radar.capture.offset_binary");
  CHECK(error_key("radar: 5\n") == "radar");
}

TEST_CASE("out-of-range value is named", "[options]") {
  CHECK(error_key("radar:\n  preset: xwr1843\n  loops: 0\n") == "radar.loops");
  CHECK(error_key("radar:\n  preset: xwr1843\n  chirp:\n    slope_mhz_per_us: -4\n") == "radar.chirp.slope_mhz_per_us");
  CHECK(error_key("radar:\n  preset: xwr1843\n  capture:\n    iq_order: j_first\n") == "radar.capture.iq_order");
  CHECK(error_key("radar:\n  preset: xwr1843\n  tx_order: [0, 7]\n") == "radar.tx_order");
  CHECK(error_key("radar:\n  preset: xwr1843\n  angle_fft_size: 48\n") == "radar.angle_fft_size");
}

TEST_CASE("missing required key is named", "[options]") {
  CHECK(error_key("radar:\n  loops: 16\n") == "radar.preset");
  CHECK(error_key("log_level: info\n") == "radar");
}

TEST_CASE("not YAML and missing files are refused with the file named", "[options]") {
  TempFile bad("radar: [1, 2\n  preset: : :\n");
  try {
    load(bad.path.string());
    FAIL("no error");
  } catch (const rsrio::ConfigError& e) {
    CHECK(e.file() == bad.path.string());
    CHECK(e.key().empty());
  }
  TempFile scalar("just a sentence\n");
  CHECK_THROWS_AS(load(scalar.path.string()), rsrio::ConfigError);
  CHECK_THROWS_AS(load("/nonexistent/rsrio.yaml"), rsrio::ConfigError);
  TempFile xml("<?xml version=\"1.0\"?>\n<opencv_storage><radar>1</radar></opencv_storage>\n");
  CHECK_THROWS_AS(load(xml.path.string()), rsrio::ConfigError);
}
