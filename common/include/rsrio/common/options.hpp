// Options files: YAML read through cv::FileStorage, validated key by key.
//
// Every program of rsrio takes `--config FILE`. Nothing may start on a half-valid file, so each
// options struct reads its keys through an OptionsNode, which checks type and range, names the
// file and the full key in every error, and rejects keys nobody read (a typo must not silently
// fall back to a default).
#pragma once

#include <complex>
#include <initializer_list>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/persistence.hpp>

namespace rsrio {

/// A configuration that cannot be used: which file, which key, what was expected.
class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, std::string key, std::string expected);
  const std::string& file() const { return file_; }
  const std::string& key() const { return key_; }
  const std::string& expected() const { return expected_; }

 private:
  std::string file_;
  std::string key_;
  std::string expected_;
};

/// Closed interval for numeric options.
template <typename T>
struct Range {
  T min = std::numeric_limits<T>::lowest();
  T max = std::numeric_limits<T>::max();
};

/// One YAML map of an options file. Cheap to copy; refers into its OptionsFile.
class OptionsNode {
 public:
  OptionsNode(cv::FileNode node, std::string file, std::string path,
              std::shared_ptr<std::vector<std::string>> read_keys);

  bool has(std::string_view key) const;
  /// Full dotted name of a key of this map, as errors print it.
  std::string key_path(std::string_view key) const;
  const std::string& file() const { return file_; }

  // Optional keys: the value keeps its default when the key is absent.
  void read(std::string_view key, double& value, Range<double> range = {});
  void read(std::string_view key, int& value, Range<int> range = {});
  void read(std::string_view key, bool& value);
  void read(std::string_view key, std::string& value);
  void read(std::string_view key, std::vector<double>& value);
  void read(std::string_view key, std::vector<int>& value, Range<int> range = {});
  /// A string that must be one of `choices`.
  void read_choice(std::string_view key, std::string& value,
                   std::initializer_list<std::string_view> choices);

  /// The key must be present; then as read().
  template <typename T, typename... Rest>
  void require(std::string_view key, T& value, Rest&&... rest) {
    if (!has(key)) fail(key, "a value (the key is required)");
    read(key, value, std::forward<Rest>(rest)...);
  }

  /// A nested map; absent keys give an empty map (unless required).
  OptionsNode child(std::string_view key, bool required = false);

  /// Throws for every key of this map that no read()/child() asked for.
  void finish() const;

  [[noreturn]] void fail(std::string_view key, const std::string& expected) const;

 private:
  cv::FileNode value_node(std::string_view key);
  std::string describe(const cv::FileNode& n) const;

  cv::FileNode node_;
  std::string file_;
  std::string path_;
  std::shared_ptr<std::vector<std::string>> read_keys_;  // full paths of keys read so far
};

/// An opened options file. Keeps the cv::FileStorage alive for its nodes.
class OptionsFile {
 public:
  /// Throws ConfigError when the file is missing, unreadable, not YAML, or not a map.
  explicit OptionsFile(const std::string& path);
  OptionsNode root();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  cv::FileStorage storage_;
  std::shared_ptr<std::vector<std::string>> read_keys_;
};

}  // namespace rsrio
