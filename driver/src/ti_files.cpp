#include "rsrio/driver/ti_files.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace rsrio {

namespace fs = std::filesystem;

namespace {

std::runtime_error file_error(const std::string& path, const std::string& what) {
  return std::runtime_error(path + ": " + what + (errno ? std::string(" (") + std::strerror(errno) + ")" : ""));
}

std::FILE* open_or_throw(const std::string& path, const char* mode) {
  errno = 0;
  std::FILE* f = std::fopen(path.c_str(), mode);
  if (!f) throw file_error(path, "cannot open");
  return f;
}

void write_all(std::FILE* f, const void* data, std::size_t n, const std::string& path) {
  if (std::fwrite(data, 1, n, f) != n) throw file_error(path, "write failed");
}

void read_at(const std::string& path, std::uint64_t offset, std::span<std::uint8_t> out) {
  std::ifstream in(path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(offset));
  in.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(out.size()));
  if (static_cast<std::size_t>(in.gcount()) != out.size()) throw std::runtime_error(path + ": short read");
}

template <typename T>
void put_le(std::uint8_t* p, T v) {
  for (std::size_t i = 0; i < sizeof(T); ++i) p[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(v) >> (8 * i));
}
template <typename T>
T get_le(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) v |= std::uint64_t(p[i]) << (8 * i);
  return static_cast<T>(v);
}

std::string chunk_file(const std::string& dir, int device, int chunk, const char* kind) {
  char name[64];
  std::snprintf(name, sizeof name, "%s_%04d_%s.bin", kCascadeDeviceNames[device], chunk, kind);
  return (fs::path(dir) / name).string();
}

}  // namespace

// ---- DCA1000 capture file ----------------------------------------------------------------------

Dca1000FileWriter::Dca1000FileWriter(const std::string& path, const RadarConfig& config)
    : path_(path), frame_bytes_(dca1000_frame_bytes(config)), file_(open_or_throw(path, "wb")) {}

Dca1000FileWriter::~Dca1000FileWriter() {
  if (file_) std::fclose(file_);
}

void Dca1000FileWriter::write(std::span<const std::uint8_t> frame) {
  if (frame.size() != frame_bytes_)
    throw std::invalid_argument(path_ + ": frame of " + std::to_string(frame.size()) + " bytes, the configuration says " +
                                std::to_string(frame_bytes_));
  write_all(file_, frame.data(), frame.size(), path_);
}

void Dca1000FileWriter::close() {
  if (file_ && std::fclose(file_) != 0) {
    file_ = nullptr;
    throw file_error(path_, "close failed");
  }
  file_ = nullptr;
}

Dca1000FileReader::Dca1000FileReader(const std::string& path, const RadarConfig& config)
    : path_(path), config_(config), frame_bytes_(dca1000_frame_bytes(config)) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) throw std::runtime_error(path + ": " + ec.message());
  frames_ = static_cast<std::size_t>(size / frame_bytes_);
  trailing_ = static_cast<std::size_t>(size % frame_bytes_);
}

void Dca1000FileReader::read(std::size_t i, std::vector<std::uint8_t>& bytes) const {
  if (i >= frames_) throw std::out_of_range(path_ + ": frame " + std::to_string(i) + " of " + std::to_string(frames_));
  bytes.resize(frame_bytes_);
  read_at(path_, std::uint64_t(i) * frame_bytes_, bytes);
}

void Dca1000FileReader::read(std::size_t i, AdcCube& cube) const {
  std::vector<std::uint8_t> bytes;
  read(i, bytes);
  decode_dca1000(config_, bytes, cube);
}

// ---- MMWCAS cascade recording --------------------------------------------------------------------

CascadeWriter::CascadeWriter(const std::string& directory, const RadarConfig& config)
    : directory_(directory), device_bytes_(cascade_device_frame_bytes(config)) {
  if (config.capture.format != "mmwcas") throw std::invalid_argument("CascadeWriter needs an mmwcas configuration");
  fs::create_directories(directory);
  std::array<std::uint8_t, kCascadeIdxHeaderBytes> header{};  // filled in by close()
  for (int d = 0; d < kCascadeDevices; ++d) {
    data_[d] = open_or_throw(chunk_file(directory, d, 0, "data"), "wb");
    idx_[d] = open_or_throw(chunk_file(directory, d, 0, "idx"), "wb");
    write_all(idx_[d], header.data(), header.size(), chunk_file(directory, d, 0, "idx"));
  }
}

CascadeWriter::~CascadeWriter() {
  try {
    close();
  } catch (...) {
  }
}

void CascadeWriter::write(std::span<const std::uint8_t> frame, std::uint64_t timestamp) {
  if (frame.size() != kCascadeDevices * device_bytes_)
    throw std::invalid_argument("cascade frame of " + std::to_string(frame.size()) + " bytes, expected " +
                                std::to_string(kCascadeDevices * device_bytes_));
  for (int d = 0; d < kCascadeDevices; ++d) {
    const std::string idx_path = chunk_file(directory_, d, 0, "idx");
    write_all(data_[d], frame.data() + d * device_bytes_, device_bytes_, chunk_file(directory_, d, 0, "data"));
    std::array<std::uint8_t, kCascadeIdxEntryBytes> e{};
    put_le<std::uint32_t>(e.data() + 28, static_cast<std::uint32_t>(device_bytes_));  // size
    put_le<std::uint64_t>(e.data() + 32, timestamp);
    put_le<std::uint64_t>(e.data() + 40, std::uint64_t(frames_) * device_bytes_);     // offset
    write_all(idx_[d], e.data(), e.size(), idx_path);
  }
  ++frames_;
}

void CascadeWriter::close() {
  for (int d = 0; d < kCascadeDevices; ++d) {
    if (!idx_[d]) continue;
    std::array<std::uint8_t, kCascadeIdxHeaderBytes> h{};
    put_le<std::uint32_t>(h.data() + 12, frames_);                                   // numIdx
    put_le<std::uint64_t>(h.data() + 16, std::uint64_t(frames_) * device_bytes_);    // dataFileSize
    std::fseek(idx_[d], 0, SEEK_SET);
    write_all(idx_[d], h.data(), h.size(), chunk_file(directory_, d, 0, "idx"));
    std::fclose(idx_[d]);
    std::fclose(data_[d]);
    idx_[d] = data_[d] = nullptr;
  }
}

CascadeReader::CascadeReader(const std::string& directory, const RadarConfig& config)
    : config_(config), device_bytes_(cascade_device_frame_bytes(config)) {
  if (config.capture.format != "mmwcas") throw std::invalid_argument("CascadeReader needs an mmwcas configuration");
  if (!fs::is_directory(directory)) throw std::runtime_error(directory + ": not a directory");
  for (int chunk = 0;; ++chunk) {
    if (!fs::exists(chunk_file(directory, 0, chunk, "idx"))) {
      if (chunk == 0) throw std::runtime_error(chunk_file(directory, 0, 0, "idx") + ": missing (not a cascade recording?)");
      break;
    }
    // Per device: the frames its index lists whose bytes are present in its data file.
    std::array<std::vector<std::pair<std::uint64_t, std::uint64_t>>, kCascadeDevices> lists;  // offset, timestamp
    for (int d = 0; d < kCascadeDevices; ++d) {
      const std::string idx = chunk_file(directory, d, chunk, "idx"), data = chunk_file(directory, d, chunk, "data");
      std::ifstream in(idx, std::ios::binary);
      if (!in) throw std::runtime_error(idx + ": missing (every device of the cascade needs its files)");
      std::error_code ec;
      const std::uint64_t data_size = fs::file_size(data, ec);
      if (ec) throw std::runtime_error(data + ": " + ec.message());
      std::array<std::uint8_t, kCascadeIdxHeaderBytes> h{};
      if (!in.read(reinterpret_cast<char*>(h.data()), h.size())) throw std::runtime_error(idx + ": shorter than its header");
      const std::uint32_t entries = get_le<std::uint32_t>(h.data() + 12);
      for (std::uint32_t i = 0; i < entries; ++i) {
        std::array<std::uint8_t, kCascadeIdxEntryBytes> e{};
        if (!in.read(reinterpret_cast<char*>(e.data()), e.size())) {
          damage_ = idx + ": index ends after " + std::to_string(i) + " of " + std::to_string(entries) + " entries";
          break;
        }
        const std::uint32_t size = get_le<std::uint32_t>(e.data() + 28);
        const std::uint64_t offset = get_le<std::uint64_t>(e.data() + 40);
        if (size != device_bytes_)
          throw std::runtime_error(idx + ": frame " + std::to_string(i) + " holds " + std::to_string(size) +
                                   " bytes, the radar configuration makes " + std::to_string(device_bytes_) +
                                   " per device (wrong configuration for this recording?)");
        if (offset + size > data_size) {
          damage_ = data + ": ends inside frame " + std::to_string(i) + " (truncated recording)";
          break;
        }
        lists[d].emplace_back(offset, get_le<std::uint64_t>(e.data() + 32));
      }
    }
    std::size_t n = lists[0].size();
    for (const auto& l : lists) n = std::min(n, l.size());
    for (std::size_t i = 0; i < n; ++i) {
      FrameRef r;
      for (int d = 0; d < kCascadeDevices; ++d) {
        r.files[d] = chunk_file(directory, d, chunk, "data");
        r.offsets[d] = lists[d][i].first;
      }
      r.timestamp = lists[0][i].second;
      frames_.push_back(std::move(r));
    }
    if (!damage_.empty()) break;
  }
}

void CascadeReader::read(std::size_t i, std::vector<std::uint8_t>& bytes) const {
  const FrameRef& r = frames_.at(i);
  bytes.resize(kCascadeDevices * device_bytes_);
  for (int d = 0; d < kCascadeDevices; ++d)
    read_at(r.files[d], r.offsets[d], std::span(bytes).subspan(d * device_bytes_, device_bytes_));
}

void CascadeReader::read(std::size_t i, AdcCube& cube) const {
  std::vector<std::uint8_t> bytes;
  read(i, bytes);
  decode_frame(config_, bytes, cube);
}

}  // namespace rsrio
