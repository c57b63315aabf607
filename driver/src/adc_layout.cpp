#include "rsrio/driver/adc_layout.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace rsrio {

namespace {

// int16 little-endian at byte offset 2*i, with the DCA1000 MSB toggle undone.
inline float sample_at(const std::uint8_t* p, std::size_t i, bool offset_binary) {
  std::uint16_t u = static_cast<std::uint16_t>(p[2 * i] | (p[2 * i + 1] << 8));
  if (offset_binary) u ^= 0x8000u;
  return static_cast<float>(static_cast<std::int16_t>(u));
}

inline std::int16_t to_int16(float v) {
  const float r = std::nearbyint(v);
  return static_cast<std::int16_t>(std::clamp(r, -32768.0f, 32767.0f));
}

inline void put_sample(std::uint8_t* p, std::size_t i, float v, bool offset_binary) {
  std::uint16_t u = static_cast<std::uint16_t>(to_int16(v));
  if (offset_binary) u ^= 0x8000u;
  p[2 * i] = static_cast<std::uint8_t>(u & 0xFF);
  p[2 * i + 1] = static_cast<std::uint8_t>(u >> 8);
}

void check_cube(const RadarConfig& config, const AdcCube& cube) {
  if (cube.loops != config.loops || cube.slots != static_cast<int>(config.tx_order.size()) ||
      cube.rx != static_cast<int>(config.array.rx_azimuth.size()) || cube.samples != config.chirp.samples_per_chirp)
    throw std::invalid_argument("ADC cube shape does not match the radar configuration");
}

void shape_cube(const RadarConfig& config, AdcCube& cube) {
  if (cube.loops != config.loops || cube.slots != static_cast<int>(config.tx_order.size()) ||
      cube.rx != static_cast<int>(config.array.rx_azimuth.size()) || cube.samples != config.chirp.samples_per_chirp)
    cube = AdcCube::for_config(config);
}

// Position of I and Q of sample n (within one chirp-RX block of N samples) in int16 units.
struct IqPos {
  std::size_t i, q;
};
inline IqPos iq_pos(std::size_t n, bool iiqq, bool q_first) {
  if (iiqq) {
    const std::size_t group = (n / 2) * 4, k = n % 2;  // [A(n) A(n+1) B(n) B(n+1)]
    return q_first ? IqPos{group + 2 + k, group + k} : IqPos{group + k, group + 2 + k};
  }
  return q_first ? IqPos{2 * n + 1, 2 * n} : IqPos{2 * n, 2 * n + 1};
}

}  // namespace

std::size_t dca1000_frame_bytes(const RadarConfig& c) {
  return static_cast<std::size_t>(c.loops) * c.tx_order.size() * c.array.rx_azimuth.size() *
         c.chirp.samples_per_chirp * 4;
}

std::size_t cascade_device_frame_bytes(const RadarConfig& c) {
  return static_cast<std::size_t>(c.loops) * c.tx_order.size() * kCascadeRxPerDevice * c.chirp.samples_per_chirp * 4;
}

std::size_t raw_frame_bytes(const RadarConfig& c) {
  return c.capture.format == "mmwcas" ? kCascadeDevices * cascade_device_frame_bytes(c) : dca1000_frame_bytes(c);
}

void decode_dca1000(const RadarConfig& c, std::span<const std::uint8_t> bytes, AdcCube& cube) {
  if (bytes.size() < dca1000_frame_bytes(c))
    throw std::invalid_argument("DCA1000 frame needs " + std::to_string(dca1000_frame_bytes(c)) + " bytes, got " +
                                std::to_string(bytes.size()));
  shape_cube(c, cube);
  const bool iiqq = c.capture.sample_layout == "iiqq";
  const bool q_first = c.capture.iq_order == "q_first";
  const bool ob = c.capture.offset_binary;
  const std::size_t n_samples = static_cast<std::size_t>(cube.samples);
  const std::size_t blocks = static_cast<std::size_t>(cube.loops) * cube.slots * cube.rx;
  // Chirps in time order, RX blocks within a chirp: exactly the cube's own order.
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::uint8_t* p = bytes.data() + b * n_samples * 4;
    std::complex<float>* out = cube.data.data() + b * n_samples;
    for (std::size_t n = 0; n < n_samples; ++n) {
      const IqPos pos = iq_pos(n, iiqq, q_first);
      out[n] = {sample_at(p, pos.i, ob), sample_at(p, pos.q, ob)};
    }
  }
}

void encode_dca1000(const RadarConfig& c, const AdcCube& cube, std::vector<std::uint8_t>& bytes) {
  check_cube(c, cube);
  bytes.resize(dca1000_frame_bytes(c));
  const bool iiqq = c.capture.sample_layout == "iiqq";
  const bool q_first = c.capture.iq_order == "q_first";
  const bool ob = c.capture.offset_binary;
  const std::size_t n_samples = static_cast<std::size_t>(cube.samples);
  const std::size_t blocks = static_cast<std::size_t>(cube.loops) * cube.slots * cube.rx;
  for (std::size_t b = 0; b < blocks; ++b) {
    std::uint8_t* p = bytes.data() + b * n_samples * 4;
    const std::complex<float>* in = cube.data.data() + b * n_samples;
    for (std::size_t n = 0; n < n_samples; ++n) {
      const IqPos pos = iq_pos(n, iiqq, q_first);
      put_sample(p, pos.i, in[n].real(), ob);
      put_sample(p, pos.q, in[n].imag(), ob);
    }
  }
}

void decode_cascade(const RadarConfig& c, const std::array<std::span<const std::uint8_t>, kCascadeDevices>& devices,
                    AdcCube& cube) {
  if (c.array.rx_azimuth.size() != kCascadeDevices * kCascadeRxPerDevice)
    throw std::invalid_argument("cascade frames need 16 RX channels in the configuration");
  const std::size_t dev_bytes = cascade_device_frame_bytes(c);
  for (const auto& d : devices)
    if (d.size() < dev_bytes)
      throw std::invalid_argument("cascade device frame needs " + std::to_string(dev_bytes) + " bytes, got " +
                                  std::to_string(d.size()));
  shape_cube(c, cube);
  const bool ob = c.capture.offset_binary;
  for (int dev = 0; dev < kCascadeDevices; ++dev) {
    const std::uint8_t* p = devices[dev].data();
    std::size_t k = 0;  // complex sample index in [loop][chirp][sample][rx]
    for (int l = 0; l < cube.loops; ++l)
      for (int s = 0; s < cube.slots; ++s)
        for (int n = 0; n < cube.samples; ++n)
          for (int r = 0; r < kCascadeRxPerDevice; ++r, ++k)
            cube.at(l, s, dev * kCascadeRxPerDevice + r, n) = {sample_at(p, 2 * k, ob), sample_at(p, 2 * k + 1, ob)};
  }
}

void encode_cascade(const RadarConfig& c, const AdcCube& cube,
                    std::array<std::vector<std::uint8_t>, kCascadeDevices>& devices) {
  check_cube(c, cube);
  if (cube.rx != kCascadeDevices * kCascadeRxPerDevice)
    throw std::invalid_argument("cascade frames need 16 RX channels");
  const bool ob = c.capture.offset_binary;
  for (int dev = 0; dev < kCascadeDevices; ++dev) {
    devices[dev].resize(cascade_device_frame_bytes(c));
    std::uint8_t* p = devices[dev].data();
    std::size_t k = 0;
    for (int l = 0; l < cube.loops; ++l)
      for (int s = 0; s < cube.slots; ++s)
        for (int n = 0; n < cube.samples; ++n)
          for (int r = 0; r < kCascadeRxPerDevice; ++r, ++k) {
            const auto v = cube.at(l, s, dev * kCascadeRxPerDevice + r, n);
            put_sample(p, 2 * k, v.real(), ob);
            put_sample(p, 2 * k + 1, v.imag(), ob);
          }
  }
}

void decode_frame(const RadarConfig& c, std::span<const std::uint8_t> bytes, AdcCube& cube) {
  if (c.capture.format != "mmwcas") {
    decode_dca1000(c, bytes, cube);
    return;
  }
  const std::size_t dev_bytes = cascade_device_frame_bytes(c);
  if (bytes.size() < kCascadeDevices * dev_bytes)
    throw std::invalid_argument("cascade frame needs " + std::to_string(kCascadeDevices * dev_bytes) +
                                " bytes, got " + std::to_string(bytes.size()));
  std::array<std::span<const std::uint8_t>, kCascadeDevices> devs;
  for (int d = 0; d < kCascadeDevices; ++d) devs[d] = bytes.subspan(d * dev_bytes, dev_bytes);
  decode_cascade(c, devs, cube);
}

void encode_frame(const RadarConfig& c, const AdcCube& cube, std::vector<std::uint8_t>& bytes) {
  if (c.capture.format != "mmwcas") {
    encode_dca1000(c, cube, bytes);
    return;
  }
  std::array<std::vector<std::uint8_t>, kCascadeDevices> devs;
  encode_cascade(c, cube, devs);
  bytes.clear();
  bytes.reserve(kCascadeDevices * cascade_device_frame_bytes(c));
  for (const auto& d : devs) bytes.insert(bytes.end(), d.begin(), d.end());
}

}  // namespace rsrio
