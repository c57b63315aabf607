// NumPy .npy files (format versions 1.0, 2.0, 3.0; C order; little-endian or byte-order-free
// dtypes): a reader with clear errors for bad files, and a writer for float32 / complex64 arrays.
// https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html
#pragma once

#include <complex>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"

namespace rsrio {

/// A .npy file that cannot be read: names the file and what is wrong.
class NpyError : public std::runtime_error {
 public:
  NpyError(const std::string& path, const std::string& what);
};

struct NpyArray {
  std::string descr;                // as in the header, e.g. "<c16", "<f4", "|u1"
  std::vector<std::size_t> shape;   // C order
  std::vector<std::uint8_t> bytes;  // raw element data, size = elements * item size
  std::size_t elements() const;
  std::size_t item_size() const;
  bool is_complex() const;
  /// Element i as a complex double (real dtypes give zero imaginary parts). Supported dtypes:
  /// c8 c16 f4 f8 i1 i2 i4 i8 u1 u2 u4 u8, little-endian or single-byte.
  std::complex<double> complex_at(std::size_t i) const;
};

/// Reads a whole .npy file. Throws NpyError (missing file, bad magic, unsupported version,
/// malformed header, Fortran order, unsupported or big-endian dtype, size mismatch / truncation).
NpyArray read_npy(const std::string& path);

/// Writes a C-order float32 ("<f4") or complex64 ("<c8") array (format 1.0). Throws NpyError.
void write_npy(const std::string& path, const float* data, const std::vector<std::size_t>& shape);
void write_npy(const std::string& path, const std::complex<float>* data,
               const std::vector<std::size_t>& shape);

/// A raw frame stored as .npy -> AdcCube for `config`. Accepted shapes: (loops, virtual, samples)
/// with virtual = slot * num_rx + rx (OpenRadar, TDM slot-major), or (loops, slots, rx, samples).
/// Values are taken as int16 ADC samples; integer values in [32768, 65535] are read as the
/// unsigned bit pattern of an int16 (v - 65536), as OpenRadar stores them. Throws NpyError when
/// the shape does not match the configuration. `openradar_bit_patterns` (optional) tells whether
/// any value needed that reinterpretation.
AdcCube npy_to_cube(const NpyArray& array, const RadarConfig& config, const std::string& path = "<npy>",
                    bool* openradar_bit_patterns = nullptr);

}  // namespace rsrio
