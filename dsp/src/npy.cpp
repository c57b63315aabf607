#include "rsrio/dsp/npy.hpp"

#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace rsrio {

namespace {

constexpr char kMagic[] = "\x93NUMPY";

std::string shape_text(const std::vector<std::size_t>& shape) {
  std::ostringstream s;
  s << "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s << (i ? ", " : "") << shape[i];
  if (shape.size() == 1) s << ",";
  s << ")";
  return s.str();
}

// Minimal parser of the header dict: {'descr': '<c16', 'fortran_order': False, 'shape': (128, 8, 128), }
struct HeaderParser {
  const std::string& h;
  const std::string& path;
  std::size_t i = 0;

  [[noreturn]] void fail(const std::string& what) const {
    throw NpyError(path, "malformed header (" + what + "): " + h);
  }
  void ws() {
    while (i < h.size() && (h[i] == ' ' || h[i] == '\t' || h[i] == '\n')) ++i;
  }
  void expect(char c) {
    ws();
    if (i >= h.size() || h[i] != c) fail(std::string("expected '") + c + "'");
    ++i;
  }
  bool peek(char c) {
    ws();
    return i < h.size() && h[i] == c;
  }
  std::string str() {
    ws();
    if (i >= h.size() || (h[i] != '\'' && h[i] != '"')) fail("expected a quoted string");
    const char q = h[i++];
    const std::size_t e = h.find(q, i);
    if (e == std::string::npos) fail("unterminated string");
    std::string s = h.substr(i, e - i);
    i = e + 1;
    return s;
  }
  std::string word() {
    ws();
    const std::size_t b = i;
    while (i < h.size() && std::isalpha(static_cast<unsigned char>(h[i]))) ++i;
    return h.substr(b, i - b);
  }
  std::vector<std::size_t> tuple() {
    expect('(');
    std::vector<std::size_t> v;
    while (!peek(')')) {
      ws();
      const std::size_t b = i;
      while (i < h.size() && std::isdigit(static_cast<unsigned char>(h[i]))) ++i;
      if (b == i) fail("expected a non-negative integer in the shape");
      v.push_back(static_cast<std::size_t>(std::stoull(h.substr(b, i - b))));
      if (peek(',')) ++i;
    }
    expect(')');
    return v;
  }
};

void parse_header(const std::string& header, const std::string& path, NpyArray& a, bool& fortran) {
  HeaderParser p{header, path};
  bool have_descr = false, have_order = false, have_shape = false;
  p.expect('{');
  while (!p.peek('}')) {
    const std::string key = p.str();
    p.expect(':');
    if (key == "descr") {
      if (p.peek('[')) throw NpyError(path, "structured dtypes are not supported (descr is a list)");
      a.descr = p.str();
      have_descr = true;
    } else if (key == "fortran_order") {
      const std::string w = p.word();
      if (w != "True" && w != "False") p.fail("fortran_order must be True or False");
      fortran = w == "True";
      have_order = true;
    } else if (key == "shape") {
      a.shape = p.tuple();
      have_shape = true;
    } else {
      p.fail("unknown key '" + key + "'");
    }
    if (p.peek(',')) ++p.i;
  }
  p.expect('}');
  if (!have_descr || !have_order || !have_shape) p.fail("needs 'descr', 'fortran_order' and 'shape'");
}

template <typename T>
T load(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

void write_file(const std::string& path, const std::string& descr, const void* data, std::size_t item,
                const std::vector<std::size_t>& shape) {
  std::size_t n = 1;
  for (auto s : shape) n *= s;
  std::string dict =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape_text(shape) + ", }";
  // magic(6) + version(2) + len(2) + dict + padding + '\n', total a multiple of 64.
  std::size_t total = 10 + dict.size() + 1;
  const std::size_t pad = (64 - total % 64) % 64;
  dict.append(pad, ' ');
  dict.push_back('\n');
  if (dict.size() > 65535) throw NpyError(path, "header too long for format 1.0");
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) throw NpyError(path, "cannot open for writing");
  f.write(kMagic, 6);
  const char version[2] = {1, 0};
  f.write(version, 2);
  const std::uint16_t len = static_cast<std::uint16_t>(dict.size());
  const char lenb[2] = {static_cast<char>(len & 0xFF), static_cast<char>(len >> 8)};
  f.write(lenb, 2);
  f.write(dict.data(), static_cast<std::streamsize>(dict.size()));
  f.write(static_cast<const char*>(data), static_cast<std::streamsize>(n * item));
  if (!f) throw NpyError(path, "write failed");
}

}  // namespace

NpyError::NpyError(const std::string& path, const std::string& what)
    : std::runtime_error(path + ": " + what) {}

std::size_t NpyArray::elements() const {
  std::size_t n = 1;
  for (auto s : shape) n *= s;
  return n;
}

std::size_t NpyArray::item_size() const {
  if (descr.size() < 3) return 0;
  return static_cast<std::size_t>(std::stoul(descr.substr(2)));
}

bool NpyArray::is_complex() const {
  return descr.size() >= 2 && descr[1] == 'c';
}

std::complex<double> NpyArray::complex_at(std::size_t i) const {
  const std::size_t w = item_size();
  const std::uint8_t* p = bytes.data() + i * w;
  const char kind = descr[1];
  switch (kind) {
    case 'c':
      if (w == 8) return {load<float>(p), load<float>(p + 4)};
      return {load<double>(p), load<double>(p + 8)};
    case 'f':
      return w == 4 ? double(load<float>(p)) : load<double>(p);
    case 'i':
      switch (w) {
        case 1:
          return double(load<std::int8_t>(p));
        case 2:
          return double(load<std::int16_t>(p));
        case 4:
          return double(load<std::int32_t>(p));
        default:
          return double(load<std::int64_t>(p));
      }
    default:  // 'u'
      switch (w) {
        case 1:
          return double(load<std::uint8_t>(p));
        case 2:
          return double(load<std::uint16_t>(p));
        case 4:
          return double(load<std::uint32_t>(p));
        default:
          return double(load<std::uint64_t>(p));
      }
  }
}

NpyArray read_npy(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw NpyError(path, "cannot open (missing file or no permission)");
  std::vector<std::uint8_t> file((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (file.size() < 10 || std::memcmp(file.data(), kMagic, 6) != 0)
    throw NpyError(path, "not a .npy file (no \\x93NUMPY magic)");
  const int major = file[6];
  std::size_t header_len = 0, header_start = 0;
  if (major == 1) {
    header_len = file[8] | (std::size_t(file[9]) << 8);
    header_start = 10;
  } else if (major == 2 || major == 3) {
    if (file.size() < 12) throw NpyError(path, "truncated header");
    header_len =
        file[8] | (std::size_t(file[9]) << 8) | (std::size_t(file[10]) << 16) | (std::size_t(file[11]) << 24);
    header_start = 12;
  } else {
    throw NpyError(
        path, "unsupported .npy format version " + std::to_string(major) + "." + std::to_string(file[7]));
  }
  if (header_start + header_len > file.size()) throw NpyError(path, "truncated header");
  const std::string header(file.begin() + static_cast<long>(header_start),
                           file.begin() + static_cast<long>(header_start + header_len));
  NpyArray a;
  bool fortran = false;
  parse_header(header, path, a, fortran);
  if (fortran) throw NpyError(path, "Fortran-order arrays are not supported (save with C order)");
  const std::string& d = a.descr;
  const bool ok_kind = d.size() >= 3 && (d[1] == 'c' || d[1] == 'f' || d[1] == 'i' || d[1] == 'u');
  if (!ok_kind) throw NpyError(path, "unsupported dtype '" + d + "' (need complex, float or integer)");
  std::size_t w = 0;
  try {
    w = a.item_size();
  } catch (const std::exception&) {
    throw NpyError(path, "unsupported dtype '" + d + "'");
  }
  const bool ok_size = (d[1] == 'c' && (w == 8 || w == 16)) || (d[1] == 'f' && (w == 4 || w == 8)) ||
                       ((d[1] == 'i' || d[1] == 'u') && (w == 1 || w == 2 || w == 4 || w == 8));
  if (!ok_size) throw NpyError(path, "unsupported dtype '" + d + "'");
  if (d[0] == '>') throw NpyError(path, "big-endian dtype '" + d + "' is not supported");
  if (d[0] != '<' && d[0] != '|' && d[0] != '=')
    throw NpyError(path, "unsupported byte order in dtype '" + d + "'");
  if (d[0] == '|' && w != 1) throw NpyError(path, "dtype '" + d + "' needs a byte order");
  const std::size_t data_start = header_start + header_len;
  const std::size_t need = a.elements() * w;
  if (file.size() - data_start < need)
    throw NpyError(path, "truncated data: shape " + shape_text(a.shape) + " of '" + d + "' needs " +
                             std::to_string(need) + " bytes, the file has " +
                             std::to_string(file.size() - data_start));
  if (file.size() - data_start > need)
    throw NpyError(path,
                   "extra bytes after the data (" + std::to_string(file.size() - data_start - need) + ")");
  a.bytes.assign(file.begin() + static_cast<long>(data_start), file.end());
  return a;
}

void write_npy(const std::string& path, const float* data, const std::vector<std::size_t>& shape) {
  write_file(path, "<f4", data, sizeof(float), shape);
}

void write_npy(const std::string& path, const std::complex<float>* data,
               const std::vector<std::size_t>& shape) {
  write_file(path, "<c8", data, sizeof(std::complex<float>), shape);
}

AdcCube npy_to_cube(const NpyArray& a, const RadarConfig& config, const std::string& path,
                    bool* bit_patterns) {
  const RadarDerived d = derive(config);
  const std::size_t L = config.loops, S = d.num_tx, R = d.num_rx, N = config.chirp.samples_per_chirp;
  const bool three = a.shape.size() == 3 && a.shape[0] == L && a.shape[1] == S * R && a.shape[2] == N;
  const bool four =
      a.shape.size() == 4 && a.shape[0] == L && a.shape[1] == S && a.shape[2] == R && a.shape[3] == N;
  if (!three && !four)
    throw NpyError(path, "shape " + shape_text(a.shape) +
                             " does not fit the radar configuration: expected (" + std::to_string(L) + ", " +
                             std::to_string(S * R) + ", " + std::to_string(N) +
                             ") = (loops, virtual channels = " + std::to_string(S) + " slots x " +
                             std::to_string(R) + " RX, samples) or (" + std::to_string(L) + ", " +
                             std::to_string(S) + ", " + std::to_string(R) + ", " + std::to_string(N) + ")");
  AdcCube cube = AdcCube::for_config(config);
  bool patterns = false;
  auto fix = [&](double v) {
    if (!std::isfinite(v)) throw NpyError(path, "non-finite sample value");
    if (v >= 32768.0 && v <= 65535.0 && v == std::floor(v)) {
      patterns = true;
      return v - 65536.0;
    }
    return v;
  };
  // Both accepted shapes have the cube's element order ([loop][slot][rx][sample]).
  for (std::size_t i = 0; i < cube.data.size(); ++i) {
    const std::complex<double> v = a.complex_at(i);
    cube.data[i] = {static_cast<float>(fix(v.real())), static_cast<float>(fix(v.imag()))};
  }
  if (bit_patterns) *bit_patterns = patterns;
  return cube;
}

}  // namespace rsrio
