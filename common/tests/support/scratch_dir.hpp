#pragma once
// The one scratch directory of the tests: every test that writes files (options files, recordings,
// images) writes them into a ScratchDir of its own. Named by the test, the process and a counter:
// ctest runs a file's test cases side by side, one process each, and several builds (release,
// asan, tsan) may run their tests at once, so a fixed name let one case read or delete another's
// files (backend_test once loaded another case's options).

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

namespace rsrio::testing {

/// A fresh directory under the system temp dir, removed with everything in it at scope exit.
class ScratchDir {
 public:
  explicit ScratchDir(std::string_view name)
      : path_(std::filesystem::temp_directory_path() / ("rsrio_" + std::string(name) + "_" +
                                                        std::to_string(::getpid()) + "_" + std::to_string(next_++))) {
    std::filesystem::remove_all(path_);  // left by a crashed process whose pid came round again
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;  // a destructor must not throw; a leftover in /tmp is harmless
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  /// The path of a file in the directory (not created).
  std::string file(std::string_view name) const { return (path_ / name).string(); }
  /// Writes text to a file in the directory and returns its path.
  std::string write(std::string_view name, std::string_view text) const {
    const std::string p = file(name);
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }

 private:
  static inline std::atomic<int> next_{0};
  std::filesystem::path path_;
};

}  // namespace rsrio::testing
