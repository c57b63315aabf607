// TI capture files: DCA1000 adc_data.bin and the MMWCAS per-device data/index files round-trip;
// the byte positions are those of TI's readers; damage reads up to the damage.
#include "rsrio/driver/ti_files.hpp"

#include <filesystem>
#include <fstream>
#include <random>

#include <catch2/catch_test_macros.hpp>

#include "scratch_dir.hpp"

namespace fs = std::filesystem;

namespace {

rsrio::AdcCube random_cube(const rsrio::RadarConfig& c, unsigned seed) {
  auto cube = rsrio::AdcCube::for_config(c);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(-2000, 2000);
  for (auto& v : cube.data) v = {float(d(rng)), float(d(rng))};
  return cube;
}

}  // namespace

TEST_CASE("DCA1000 capture file: frames back to back, trailing padding reported", "[ti_files]") {
  auto c = rsrio::radar_preset("xwr1843");
  c.loops = 4;
  const rsrio::testing::ScratchDir dir("ti_files_test");
  const std::string path = dir.file("adc_data.bin");
  std::vector<rsrio::AdcCube> cubes;
  {
    rsrio::Dca1000FileWriter w(path, c);
    for (unsigned i = 0; i < 3; ++i) {
      cubes.push_back(random_cube(c, i));
      std::vector<std::uint8_t> bytes;
      rsrio::encode_dca1000(c, cubes.back(), bytes);
      w.write(bytes);
    }
    w.close();
  }
  CHECK(fs::file_size(path) == 3 * rsrio::dca1000_frame_bytes(c));
  { std::ofstream(path, std::ios::app | std::ios::binary) << std::string(1000, '\0'); }  // TI's zero padding
  rsrio::Dca1000FileReader r(path, c);
  CHECK(r.frames() == 3);
  CHECK(r.trailing_bytes() == 1000);
  for (std::size_t i = 0; i < 3; ++i) {
    rsrio::AdcCube back;
    r.read(i, back);
    CHECK(back.data == cubes[i].data);
  }
  rsrio::AdcCube none;
  CHECK_THROWS_AS(r.read(3, none), std::out_of_range);
}

TEST_CASE("cascade recording: per-device data and index files round-trip into 4-chip frames", "[ti_files]") {
  auto c = rsrio::radar_preset("mmwcas");
  c.loops = 2;
  c.chirp.samples_per_chirp = 32;
  c.chirp.ramp_end_time_us = 20.0;
  rsrio::validate(c);
  const rsrio::testing::ScratchDir dir("ti_files_test");
  std::vector<rsrio::AdcCube> cubes;
  {
    rsrio::CascadeWriter w(dir.path().string(), c);
    for (unsigned i = 0; i < 4; ++i) {
      cubes.push_back(random_cube(c, 10 + i));
      std::vector<std::uint8_t> bytes;
      rsrio::encode_frame(c, cubes.back(), bytes);
      w.write(bytes, 1000000ull * i);
    }
  }
  for (const char* dev : {"master", "slave1", "slave2", "slave3"}) {
    CHECK(fs::file_size(dir.path() / (std::string(dev) + "_0000_data.bin")) == 4 * rsrio::cascade_device_frame_bytes(c));
    CHECK(fs::file_size(dir.path() / (std::string(dev) + "_0000_idx.bin")) == 24 + 4 * 48);
  }
  // The index header as TI's getValidNumFrames reads it: numIdx is the 4th uint32.
  std::ifstream idx(dir.path() / "slave2_0000_idx.bin", std::ios::binary);
  std::uint32_t h[6];
  idx.read(reinterpret_cast<char*>(h), sizeof h);
  CHECK(h[3] == 4);
  CHECK(h[4] == 4 * rsrio::cascade_device_frame_bytes(c));

  rsrio::CascadeReader r(dir.path().string(), c);
  REQUIRE(r.frames() == 4);
  CHECK(r.damage().empty());
  CHECK(r.timestamp(3) == 3000000);
  for (std::size_t i = 0; i < 4; ++i) {
    rsrio::AdcCube back;
    r.read(i, back);
    CHECK(back.data == cubes[i].data);
  }
  // Cut slave3's data inside frame 2: frames 0 and 1 still read, the damage is named.
  fs::resize_file(dir.path() / "slave3_0000_data.bin", 2 * rsrio::cascade_device_frame_bytes(c) + 100);
  rsrio::CascadeReader cut(dir.path().string(), c);
  CHECK(cut.frames() == 2);
  CHECK(cut.damage().find("slave3_0000_data.bin: ends inside frame 2") != std::string::npos);
  // A configuration that does not match the recording is refused with the reason.
  auto wrong = c;
  wrong.loops = 3;
  CHECK_THROWS_AS(rsrio::CascadeReader(dir.path().string(), wrong), std::runtime_error);
  CHECK_THROWS_AS(rsrio::CascadeReader((dir.path() / "nothing").string(), c), std::runtime_error);
}
