// .npy reader / writer: round trips, the real OpenRadar file, and a clear error for each kind of
// bad file.
#include "rsrio/dsp/npy.hpp"

#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_string.hpp>
#include <complex>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "scratch_dir.hpp"

using namespace rsrio;
using Catch::Matchers::ContainsSubstring;

namespace {

std::string temp_path(const std::string& name) {
  static const rsrio::testing::ScratchDir dir("npy_test");
  return dir.file(name);
}

void write_bytes(const std::string& path, const std::string& header_dict, std::size_t data_bytes,
                 int major = 1) {
  std::string dict = header_dict;
  while ((10 + dict.size() + 1) % 64) dict.push_back(' ');
  dict.push_back('\n');
  std::ofstream f(path, std::ios::binary);
  f.write("\x93NUMPY", 6);
  f.put(static_cast<char>(major));
  f.put(0);
  f.put(static_cast<char>(dict.size() & 0xFF));
  f.put(static_cast<char>(dict.size() >> 8));
  f.write(dict.data(), static_cast<std::streamsize>(dict.size()));
  std::vector<char> zeros(data_bytes, 0);
  f.write(zeros.data(), static_cast<std::streamsize>(zeros.size()));
}

void expect_error(const std::string& path, const std::string& what) {
  try {
    (void)read_npy(path);
    FAIL("no error for " << path);
  } catch (const NpyError& e) {
    INFO(e.what());
    CHECK_THAT(std::string(e.what()), ContainsSubstring(path));
    CHECK_THAT(std::string(e.what()), ContainsSubstring(what));
  }
}

}  // namespace

TEST_CASE("npy: float32 and complex64 round trip", "[npy]") {
  const std::string p = temp_path("f.npy");
  std::vector<float> v(2 * 3 * 5);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<float>(i) * 0.5f - 3;
  write_npy(p, v.data(), {2, 3, 5});
  const NpyArray a = read_npy(p);
  CHECK(a.descr == "<f4");
  CHECK(a.shape == std::vector<std::size_t>{2, 3, 5});
  REQUIRE(a.elements() == v.size());
  for (std::size_t i = 0; i < v.size(); ++i) CHECK(a.complex_at(i).real() == v[i]);
  // header block is a multiple of 64 bytes, as NumPy writes it
  CHECK((std::filesystem::file_size(p) - v.size() * 4) % 64 == 0);

  const std::string q = temp_path("c.npy");
  std::vector<std::complex<float>> c = {{1, 2}, {-3, 4.5f}, {0, -1}};
  write_npy(q, c.data(), {3});
  const NpyArray b = read_npy(q);
  CHECK(b.descr == "<c8");
  CHECK(b.shape == std::vector<std::size_t>{3});
  CHECK(b.complex_at(1) == std::complex<double>(-3, 4.5));
}

TEST_CASE("npy: the real OpenRadar frame", "[npy]") {
  const NpyArray a = read_npy("../shared/data/openradar/doppler_example_1.npy");
  CHECK(a.descr == "<c16");
  CHECK(a.shape == std::vector<std::size_t>{128, 8, 128});
  RadarConfig c = radar_preset("xwr1843");
  c.loops = 128;
  c.chirp.samples_per_chirp = 128;
  c.tx_order = {0, 2};
  bool patterns = false;
  const AdcCube cube = npy_to_cube(a, c, "x.npy", &patterns);
  CHECK(patterns);
  // every sample is back on the int16 scale
  bool in_range = true;
  for (const auto& s : cube.data)
    in_range = in_range && s.real() >= -32768 && s.real() <= 32767 && s.imag() >= -32768 && s.imag() <= 32767;
  CHECK(in_range);
  // uint16 patterns >= 32768 are negative int16
  const std::complex<double> raw = a.complex_at(0);
  const std::complex<float> got = cube.data[0];
  CHECK(got.real() == static_cast<float>(raw.real() >= 32768 ? raw.real() - 65536 : raw.real()));
  // a configuration of another shape is refused with the expected shape in the message
  c.loops = 64;
  try {
    (void)npy_to_cube(a, c, "x.npy");
    FAIL("no error");
  } catch (const NpyError& e) {
    CHECK_THAT(std::string(e.what()), ContainsSubstring("(128, 8, 128) does not fit"));
    CHECK_THAT(std::string(e.what()), ContainsSubstring("expected (64, 8, 128)"));
  }
}

TEST_CASE("npy: bad files give clear errors", "[npy]") {
  SECTION("missing") {
    expect_error(temp_path("absent.npy"), "cannot open");
  }
  SECTION("not npy") {
    const std::string p = temp_path("text.npy");
    std::ofstream(p) << "hello, this is not a numpy file";
    expect_error(p, "not a .npy file");
  }
  SECTION("truncated data") {
    const std::string p = temp_path("trunc.npy");
    write_bytes(p, "{'descr': '<f4', 'fortran_order': False, 'shape': (10, 10), }", 399);
    expect_error(p, "truncated data");
  }
  SECTION("extra data") {
    const std::string p = temp_path("extra.npy");
    write_bytes(p, "{'descr': '<f4', 'fortran_order': False, 'shape': (10,), }", 44);
    expect_error(p, "extra bytes");
  }
  SECTION("Fortran order") {
    const std::string p = temp_path("fortran.npy");
    write_bytes(p, "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 2), }", 16);
    expect_error(p, "Fortran-order");
  }
  SECTION("big endian") {
    const std::string p = temp_path("be.npy");
    write_bytes(p, "{'descr': '>f8', 'fortran_order': False, 'shape': (2,), }", 16);
    expect_error(p, "big-endian");
  }
  SECTION("unsupported dtype") {
    const std::string p = temp_path("str.npy");
    write_bytes(p, "{'descr': '<U8', 'fortran_order': False, 'shape': (2,), }", 64);
    expect_error(p, "unsupported dtype");
  }
  SECTION("malformed header") {
    const std::string p = temp_path("hdr.npy");
    write_bytes(p, "{'descr': '<f4', 'fortran_order': False, 'shape': (2, x), }", 16);
    expect_error(p, "malformed header");
  }
  SECTION("unknown version") {
    const std::string p = temp_path("v9.npy");
    write_bytes(p, "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }", 8, 9);
    expect_error(p, "unsupported .npy format version 9");
  }
}
