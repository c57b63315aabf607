// Byte layouts of raw ADC frames as TI capture hardware produces them, both ways:
// decode (bytes -> AdcCube) for the DSP and the recorders, encode (AdcCube -> bytes) for the
// simulator and the board emulator. Layout facts: shared/reference/driver_dsp.md Sec. 1-2.
//
// DCA1000 (capture.format "dca1000"): one little-endian int16 stream per frame, chirps in time
// order (loop-major, TDM slot-minor), per chirp the RX channels one after another, per RX the
// samples. Sample encoding per capture.sample_layout / iq_order:
//   iiqq + i_first: groups [I(n) I(n+1) Q(n) Q(n+1)]  (TI tools, 2 LVDS lanes: "2I then 2Q")
//   iiqq + q_first: groups [Q(n) Q(n+1) I(n) I(n+1)]  (SDK demo with adcbufCfg sample swap)
//   iq   + i_first: pairs [I(n) Q(n)];  iq + q_first: pairs [Q(n) I(n)]
// offset_binary: each int16 has bit 15 flipped (DCA1000 MSB toggle).
//
// MMWCAS (capture.format "mmwcas"): four device buffers (master, slave1, slave2, slave3), each
// int16 I/Q interleaved in the order [loop][chirp (TDM slot)][sample][rx 0..3]; device d carries
// capture RX channels 4d..4d+3.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"

namespace rsrio {

inline constexpr int kCascadeDevices = 4;
inline constexpr int kCascadeRxPerDevice = 4;

/// Bytes of one frame in the DCA1000 stream.
std::size_t dca1000_frame_bytes(const RadarConfig& config);
/// Bytes of one frame of one cascade device file.
std::size_t cascade_device_frame_bytes(const RadarConfig& config);

/// DCA1000 stream bytes -> cube. `bytes` must hold dca1000_frame_bytes(config).
void decode_dca1000(const RadarConfig& config, std::span<const std::uint8_t> bytes, AdcCube& cube);
/// Cube -> DCA1000 stream bytes; samples are rounded and saturated to int16.
void encode_dca1000(const RadarConfig& config, const AdcCube& cube, std::vector<std::uint8_t>& bytes);

/// One frame of each cascade device (master, slave1..3) -> cube.
void decode_cascade(const RadarConfig& config, const std::array<std::span<const std::uint8_t>, kCascadeDevices>& devices,
                    AdcCube& cube);
void encode_cascade(const RadarConfig& config, const AdcCube& cube,
                    std::array<std::vector<std::uint8_t>, kCascadeDevices>& devices);

/// The bytes a recording stores for one frame, whatever the format: the DCA1000 stream, or the
/// four cascade device frames concatenated master..slave3. Decode/encode dispatch on the format.
std::size_t raw_frame_bytes(const RadarConfig& config);
void decode_frame(const RadarConfig& config, std::span<const std::uint8_t> bytes, AdcCube& cube);
void encode_frame(const RadarConfig& config, const AdcCube& cube, std::vector<std::uint8_t>& bytes);

}  // namespace rsrio
