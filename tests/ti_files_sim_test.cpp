// TI capture files round-trip with the simulator's frames, for both presets: the simulator's
// cube is the ground truth, the file is written by the driver's writers, and its bytes are read
// back twice: by the driver's readers, and by an independent reader here that indexes the files
// the way TI's scripts do (readDCA1000.m for the 2-lane LVDS stream; the MMWCAS per-device
// [loop][chirp][sample][rx 4] I/Q layout of TI's cascade scripts), so a layout mistake shared by
// the encoder and the decoder cannot pass.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/driver/ti_files.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;

namespace {

std::vector<std::int16_t> read_int16(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::int16_t> v(bytes.size() / 2);
  std::memcpy(v.data(), bytes.data(), v.size() * 2);  // little-endian host, as the files
  return v;
}

// What the ADC would have produced: the simulated value rounded to nearest (ties to even, the
// IEEE default the encoder uses) and saturated to int16.
std::int16_t quantised(float v) {
  return static_cast<std::int16_t>(std::clamp(std::nearbyint(v), -32768.0f, 32767.0f));
}

std::vector<rsrio::AdcCube> simulate(rsrio::sim::Scenario scenario, int frames) {
  rsrio::sim::Simulation sim(scenario, 2);
  std::vector<rsrio::AdcCube> cubes(static_cast<std::size_t>(frames));
  for (int k = 0; k < frames; ++k) sim.radar().simulate(static_cast<std::uint64_t>(k), cubes[static_cast<std::size_t>(k)]);
  return cubes;
}

}  // namespace

TEST_CASE("adc_data.bin of simulated xwr1843 frames reads back as TI's readDCA1000 reads it", "[ti_files][sim]") {
  rsrio::sim::Scenario scenario = rsrio::sim::load_scenario("scenarios/test_tiny.yaml");
  const rsrio::RadarConfig& c = scenario.radar;
  REQUIRE(c.capture.format == "dca1000");
  REQUIRE(c.capture.sample_layout == "iiqq");
  REQUIRE(c.capture.iq_order == "i_first");
  const auto cubes = simulate(scenario, 3);
  const rsrio::testing::ScratchDir dir("ti_files_sim_xwr1843");
  const fs::path file = dir.path() / "adc_data.bin";
  {
    rsrio::Dca1000FileWriter w(file.string(), c);
    std::vector<std::uint8_t> bytes;
    for (const auto& cube : cubes) {
      rsrio::encode_frame(c, cube, bytes);
      w.write(bytes);
    }
    w.close();
  }
  const auto raw = read_int16(file);
  const int rx = cubes[0].rx, n = cubes[0].samples, slots = cubes[0].slots;
  REQUIRE(raw.size() == 3 * std::size_t(cubes[0].loops) * slots * rx * n * 2);
  std::size_t mismatches = 0, nonzero = 0;
  for (std::size_t k = 0; k < cubes.size(); ++k) {
    const auto& cube = cubes[k];
    for (int loop = 0; loop < cube.loops; ++loop)
      for (int slot = 0; slot < slots; ++slot)
        for (int r = 0; r < rx; ++r)
          for (int s = 0; s < n; ++s) {
            // readDCA1000.m, 2 LVDS lanes: per chirp the RX blocks, per RX groups [I I Q Q].
            const std::size_t chirp = (k * cube.loops + std::size_t(loop)) * slots + std::size_t(slot);
            const std::size_t base = (chirp * rx + std::size_t(r)) * n * 2;
            const std::size_t group = base + std::size_t(s / 2) * 4 + std::size_t(s % 2);
            const auto expected = cube.at(loop, slot, r, s);
            mismatches += raw[group] != quantised(expected.real());
            mismatches += raw[group + 2] != quantised(expected.imag());
            nonzero += raw[group] != 0;
          }
  }
  CHECK(mismatches == 0);
  CHECK(nonzero > raw.size() / 4);  // the frames carry signal and noise, not zeros

  rsrio::Dca1000FileReader reader(file.string(), c);
  REQUIRE(reader.frames() == 3);
  CHECK(reader.trailing_bytes() == 0);
  for (std::size_t k = 0; k < 3; ++k) {
    rsrio::AdcCube back;
    reader.read(k, back);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < back.data.size(); ++i)
      wrong += back.data[i] != std::complex<float>(quantised(cubes[k].data[i].real()), quantised(cubes[k].data[i].imag()));
    CHECK(wrong == 0);
  }
}

TEST_CASE("cascade device files of simulated mmwcas frames read back as TI's cascade scripts read them",
          "[ti_files][sim]") {
  rsrio::sim::Scenario scenario = rsrio::sim::load_scenario("scenarios/test_tiny.yaml");
  const double period = scenario.radar.frame_period_ms;
  scenario.radar = rsrio::radar_preset("mmwcas");
  scenario.radar.frame_period_ms = period;
  scenario.radar.loops = 4;  // keeps the test fast; the layout does not depend on it
  rsrio::validate(scenario.radar);
  const rsrio::RadarConfig& c = scenario.radar;
  const auto cubes = simulate(scenario, 2);
  const rsrio::testing::ScratchDir dir("ti_files_sim_mmwcas");
  {
    rsrio::CascadeWriter w(dir.path().string(), c);
    std::vector<std::uint8_t> bytes;
    for (std::size_t k = 0; k < cubes.size(); ++k) {
      rsrio::encode_frame(c, cubes[k], bytes);
      w.write(bytes, 1000 * k);
    }
    w.close();
  }
  const int slots = cubes[0].slots, n = cubes[0].samples;
  REQUIRE(cubes[0].rx == rsrio::kCascadeDevices * rsrio::kCascadeRxPerDevice);
  std::size_t mismatches = 0, nonzero = 0;
  for (int d = 0; d < rsrio::kCascadeDevices; ++d) {
    const auto raw = read_int16(dir.path() / (std::string(rsrio::kCascadeDeviceNames[std::size_t(d)]) + "_0000_data.bin"));
    REQUIRE(raw.size() == cubes.size() * std::size_t(cubes[0].loops) * slots * n * 4 * 2);
    for (std::size_t k = 0; k < cubes.size(); ++k) {
      const auto& cube = cubes[k];
      for (int loop = 0; loop < cube.loops; ++loop)
        for (int slot = 0; slot < slots; ++slot)
          for (int s = 0; s < n; ++s)
            for (int r = 0; r < 4; ++r) {
              const std::size_t i =
                  ((((k * cube.loops + std::size_t(loop)) * slots + std::size_t(slot)) * n + std::size_t(s)) * 4 +
                   std::size_t(r)) * 2;
              const auto expected = cube.at(loop, slot, 4 * d + r, s);  // device d: capture RX 4d..4d+3
              mismatches += raw[i] != quantised(expected.real());
              mismatches += raw[i + 1] != quantised(expected.imag());
              nonzero += raw[i] != 0;
            }
    }
  }
  CHECK(mismatches == 0);
  CHECK(nonzero > 0);

  rsrio::CascadeReader reader(dir.path().string(), c);
  REQUIRE(reader.frames() == 2);
  CHECK(reader.damage().empty());
  CHECK(reader.timestamp(1) == 1000);
  for (std::size_t k = 0; k < 2; ++k) {
    rsrio::AdcCube back;
    reader.read(k, back);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < back.data.size(); ++i)
      wrong += back.data[i] != std::complex<float>(quantised(cubes[k].data[i].real()), quantised(cubes[k].data[i].imag()));
    CHECK(wrong == 0);
  }
}
