// Capture files of TI's own tools, read and written byte for byte:
//
//  * DCA1000 capture file (`adc_data.bin` from mmWave Studio, `<prefix>_Raw_<n>.bin` from the
//    DCA1000EVM CLI): the raw LVDS stream, frames back to back, no header. TI's files may carry
//    zero padding at the end (Xiangyu-Gao issue #5), so the reader reports a trailing partial frame
//    instead of failing.
//  * MMWCAS cascade recording (MMWCAS-DSP-EVM / TDA2): per device `master|slave1|slave2|slave3`
//    `_<chunk>_data.bin` (frames back to back, [loop][chirp][sample][rx 4] I/Q int16) with
//    `_<chunk>_idx.bin` (24-byte header {u32 tag, version, flags, numIdx; u64 dataFileSize}, then
//    48-byte entries {u16 tag, version; u32 flags; u16 width, height; u32 pitchOrMetaSize[4];
//    u32 size; u64 timestamp; u64 offset}), per TI getValidNumFrames.m. Frames are assembled into
//    4-chip frames in capture RX order (master RX0-3, slave1, slave2, slave3).
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/driver/adc_layout.hpp"

namespace rsrio {

inline constexpr std::size_t kCascadeIdxHeaderBytes = 24;
inline constexpr std::size_t kCascadeIdxEntryBytes = 48;
static_assert(kCascadeIdxHeaderBytes == 4 * sizeof(std::uint32_t) + sizeof(std::uint64_t));
static_assert(kCascadeIdxEntryBytes == 2 * 2 + 4 + 2 * 2 + 4 * 4 + 4 + 8 + 8);

/// Device file names of the cascade, in capture RX order.
inline constexpr std::array<const char*, kCascadeDevices> kCascadeDeviceNames = {"master", "slave1", "slave2",
                                                                                  "slave3"};

/// Appends frames to a DCA1000 capture file. Throws std::runtime_error naming the file.
class Dca1000FileWriter {
 public:
  Dca1000FileWriter(const std::string& path, const RadarConfig& config);
  ~Dca1000FileWriter();
  void write(std::span<const std::uint8_t> frame_bytes);
  void close();

 private:
  std::string path_;
  std::size_t frame_bytes_;
  std::FILE* file_ = nullptr;
};

class Dca1000FileReader {
 public:
  Dca1000FileReader(const std::string& path, const RadarConfig& config);
  std::size_t frames() const { return frames_; }
  /// Bytes after the last whole frame (TI padding or a cut file).
  std::size_t trailing_bytes() const { return trailing_; }
  /// Reads frame `i` (bytes as captured). Throws std::out_of_range / std::runtime_error.
  void read(std::size_t i, std::vector<std::uint8_t>& bytes) const;
  void read(std::size_t i, AdcCube& cube) const;

 private:
  std::string path_;
  RadarConfig config_;
  std::size_t frame_bytes_;
  std::size_t frames_ = 0;
  std::size_t trailing_ = 0;
};

/// Writes a cascade recording directory (chunk 0000): the four data files and their index files.
class CascadeWriter {
 public:
  CascadeWriter(const std::string& directory, const RadarConfig& config);
  ~CascadeWriter();
  /// One 4-chip frame (the bytes of encode_frame for an mmwcas config), with its timestamp.
  void write(std::span<const std::uint8_t> frame_bytes, std::uint64_t timestamp);
  void close();  // writes the index headers

 private:
  std::string directory_;
  std::size_t device_bytes_;
  std::array<std::FILE*, kCascadeDevices> data_{};
  std::array<std::FILE*, kCascadeDevices> idx_{};
  std::uint32_t frames_ = 0;
};

/// Reads a cascade recording directory (all chunks 0000, 0001, ... in order).
class CascadeReader {
 public:
  /// Throws std::runtime_error naming the file and what is wrong (missing device, index that does
  /// not match the configuration's frame size, data shorter than its index says).
  CascadeReader(const std::string& directory, const RadarConfig& config);
  std::size_t frames() const { return frames_.size(); }
  std::uint64_t timestamp(std::size_t i) const { return frames_.at(i).timestamp; }
  /// A short note when the recording ends in damage (frames up to it are readable), else empty.
  const std::string& damage() const { return damage_; }
  void read(std::size_t i, std::vector<std::uint8_t>& bytes) const;  // master..slave3 concatenated
  void read(std::size_t i, AdcCube& cube) const;

 private:
  struct FrameRef {
    std::array<std::string, kCascadeDevices> files;
    std::array<std::uint64_t, kCascadeDevices> offsets;
    std::uint64_t timestamp;
  };
  RadarConfig config_;
  std::size_t device_bytes_;
  std::vector<FrameRef> frames_;
  std::string damage_;
};

}  // namespace rsrio
