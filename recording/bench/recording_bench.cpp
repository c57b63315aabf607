// rsrio-recording-bench: what recording one raw radar frame costs, next to what it must cost at
// least (copying its bytes once and checksumming them once). Runs for about a second.
//
// write() to /dev/null is the recorder's CPU cost (serialise into the chunk + CRC + bookkeeping);
// write() to a file adds the kernel's copy into the page cache, which the OS pays either way.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include "../src/crc32.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/recording/recording.hpp"

namespace {

using Clock = std::chrono::steady_clock;

template <typename Work>
double median_ms(int repeats, Work&& work) {
  std::vector<double> times;
  for (int i = 0; i < repeats; ++i) {
    const auto start = Clock::now();
    work(i);
    times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

}  // namespace

int main() {
  constexpr std::size_t kFrameBytes = 3 * 1024 * 1024;
  constexpr int kRepeats = 40;

  rsrio_msgs::msg::RadarFrame frame;
  frame.header().frame_id("radar");
  frame.config(rsrio::to_msg(rsrio::radar_preset("xwr1843")));
  std::vector<std::uint8_t> adc(kFrameBytes);
  std::mt19937 random(1);
  for (auto& b : adc) b = static_cast<std::uint8_t>(random());
  frame.adc(adc);

  std::vector<std::uint8_t> copy(kFrameBytes);
  volatile std::uint32_t sink = 0;
  const double memcpy_ms = median_ms(kRepeats, [&](int i) {
    std::memcpy(copy.data(), adc.data(), kFrameBytes);
    sink = sink + copy[static_cast<std::size_t>(i)];
  });
  const double crc_ms = median_ms(kRepeats, [&](int) { sink = rsrio::recording_detail::crc32(adc.data(), kFrameBytes); });

  auto write_ms = [&](const std::string& path) {
    rsrio::RecordingWriter writer(path);  // default 4 MiB chunks: a chunk is written every 2nd frame
    const double ms = median_ms(kRepeats, [&](int i) {
      frame.frame_number(static_cast<std::uint64_t>(i));
      writer.write(rsrio::topics::kRadarRaw, frame, 1'700'000'000'000'000'000ull + static_cast<std::uint64_t>(i));
    });
    writer.close();
    return ms;
  };
  const double null_ms = write_ms("/dev/null");
  // Named after the process: two benches at once (CI beside a developer's run) write files of their own.
  const std::string file =
      (std::filesystem::temp_directory_path() / ("rsrio-recording-bench-" + std::to_string(getpid()) + ".mcap")).string();
  const double file_ms = write_ms(file);
  std::filesystem::remove(file);

  std::printf("rsrio-recording-bench: recording one %zu-byte raw frame (median of %d)\n", kFrameBytes, kRepeats);
  std::printf("  %-34s %8.3f ms\n", "memcpy", memcpy_ms);
  std::printf("  %-34s %8.3f ms\n", "crc32 (slicing-by-8)", crc_ms);
  std::printf("  %-34s %8.3f ms  (%.2f x memcpy + crc32)\n", "write() to /dev/null", null_ms,
              null_ms / (memcpy_ms + crc_ms));
  std::printf("  %-34s %8.3f ms  (%.2f x memcpy + crc32)\n", "write() to a file", file_ms,
              file_ms / (memcpy_ms + crc_ms));
  return 0;
}
