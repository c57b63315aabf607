#include "rsrio/common/options.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>

namespace rsrio {

namespace {

std::string format_range(double lo, double hi) {
  std::ostringstream s;
  s << "[" << lo << ", " << hi << "]";
  return s.str();
}

bool is_number(const cv::FileNode& n) { return n.isInt() || n.isReal(); }

}  // namespace

ConfigError::ConfigError(std::string file, std::string key, std::string expected)
    : std::runtime_error(file + ": " + (key.empty() ? std::string{} : "key '" + key + "': ") +
                         "expected " + expected),
      file_(std::move(file)),
      key_(std::move(key)),
      expected_(std::move(expected)) {}

OptionsNode::OptionsNode(cv::FileNode node, std::string file, std::string path,
                         std::shared_ptr<std::vector<std::string>> read_keys)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)),
      read_keys_(std::move(read_keys)) {}

std::string OptionsNode::key_path(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

bool OptionsNode::has(std::string_view key) const {
  if (!node_.isMap()) return false;
  const cv::FileNode n = node_[std::string(key)];
  return !n.empty() && !n.isNone();
}

void OptionsNode::fail(std::string_view key, const std::string& expected) const {
  throw ConfigError(file_, key_path(key), expected);
}

std::string OptionsNode::describe(const cv::FileNode& n) const {
  if (n.isString()) return "'" + n.string() + "'";
  if (n.isInt()) return std::to_string(static_cast<int>(n));
  if (n.isReal()) {
    std::ostringstream s;
    s << static_cast<double>(n);
    return s.str();
  }
  if (n.isSeq()) return "a list";
  if (n.isMap()) return "a map";
  return "nothing";
}

cv::FileNode OptionsNode::value_node(std::string_view key) {
  read_keys_->push_back(key_path(key));
  return node_[std::string(key)];
}

void OptionsNode::read(std::string_view key, double& value, Range<double> range) {
  if (!has(key)) return;
  const cv::FileNode n = value_node(key);
  const std::string want = "a number in " + format_range(range.min, range.max);
  if (!is_number(n)) fail(key, want + ", got " + describe(n));
  const double v = static_cast<double>(n);
  if (!std::isfinite(v) || v < range.min || v > range.max) fail(key, want + ", got " + describe(n));
  value = v;
}

void OptionsNode::read(std::string_view key, int& value, Range<int> range) {
  if (!has(key)) return;
  const cv::FileNode n = value_node(key);
  const std::string want = "an integer in " + format_range(range.min, range.max);
  if (!n.isInt()) fail(key, want + ", got " + describe(n));
  const int v = static_cast<int>(n);
  if (v < range.min || v > range.max) fail(key, want + ", got " + describe(n));
  value = v;
}

void OptionsNode::read(std::string_view key, bool& value) {
  if (!has(key)) return;
  const cv::FileNode n = value_node(key);
  // cv::FileStorage has no boolean type: YAML true/false arrive as strings.
  if (n.isString()) {
    const std::string s = n.string();
    if (s == "true") { value = true; return; }
    if (s == "false") { value = false; return; }
  } else if (n.isInt() && (static_cast<int>(n) == 0 || static_cast<int>(n) == 1)) {
    value = static_cast<int>(n) == 1;
    return;
  }
  fail(key, "true or false, got " + describe(n));
}

void OptionsNode::read(std::string_view key, std::string& value) {
  if (!has(key)) return;
  const cv::FileNode n = value_node(key);
  if (!n.isString()) fail(key, "a string, got " + describe(n));
  value = n.string();
}

void OptionsNode::read(std::string_view key, std::vector<double>& value) {
  if (!has(key)) return;
  const cv::FileNode n = value_node(key);
  if (!n.isSeq()) fail(key, "a list of numbers, got " + describe(n));
  std::vector<double> out;
  for (const auto& e : n) {
    if (!is_number(e)) fail(key, "a list of numbers, got an element " + describe(e));
    out.push_back(static_cast<double>(e));
    if (!std::isfinite(out.back())) fail(key, "a list of finite numbers");
  }
  value = std::move(out);
}

void OptionsNode::read(std::string_view key, std::vector<int>& value, Range<int> range) {
  if (!has(key)) return;
  const cv::FileNode n = value_node(key);
  const std::string want = "a list of integers in " + format_range(range.min, range.max);
  if (!n.isSeq()) fail(key, want + ", got " + describe(n));
  std::vector<int> out;
  for (const auto& e : n) {
    if (!e.isInt()) fail(key, want + ", got an element " + describe(e));
    const int v = static_cast<int>(e);
    if (v < range.min || v > range.max) fail(key, want + ", got an element " + describe(e));
    out.push_back(v);
  }
  value = std::move(out);
}

void OptionsNode::read_choice(std::string_view key, std::string& value,
                              std::initializer_list<std::string_view> choices) {
  if (!has(key)) return;
  std::string want = "one of";
  for (auto c : choices) want += " '" + std::string(c) + "'";
  const cv::FileNode n = value_node(key);
  if (!n.isString()) fail(key, want + ", got " + describe(n));
  const std::string s = n.string();
  if (std::find(choices.begin(), choices.end(), s) == choices.end()) fail(key, want + ", got '" + s + "'");
  value = s;
}

OptionsNode OptionsNode::child(std::string_view key, bool required) {
  if (!has(key)) {
    if (required) fail(key, "a map (the section is required)");
    return OptionsNode(cv::FileNode(), file_, key_path(key), read_keys_);
  }
  const cv::FileNode n = value_node(key);
  if (!n.isMap()) fail(key, "a map of options, got " + describe(n));
  return OptionsNode(n, file_, key_path(key), read_keys_);
}

void OptionsNode::finish() const {
  if (!node_.isMap()) return;
  for (const auto& k : node_.keys()) {
    const std::string full = key_path(k);
    if (std::find(read_keys_->begin(), read_keys_->end(), full) == read_keys_->end())
      throw ConfigError(file_, full, "no such key here (unknown option; check its spelling and section)");
  }
}

OptionsFile::OptionsFile(const std::string& path)
    : path_(path), read_keys_(std::make_shared<std::vector<std::string>>()) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) throw ConfigError(path, "", "an existing file (it does not exist)");
  if (!fs::is_regular_file(path, ec)) throw ConfigError(path, "", "a regular file");
  if (!std::ifstream(path).good()) throw ConfigError(path, "", "a readable file (permission denied?)");
  // OpenCV would print its own parse error on stderr before throwing; the ConfigError says it.
  const auto previous = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  // cv::FileStorage insists on its "%YAML:1.0" directive; people write plain YAML. Give it the
  // directive when the file has none (and no other), reading the text from memory.
  std::ostringstream buffer;
  buffer << std::ifstream(path, std::ios::binary).rdbuf();
  std::string text = buffer.str();
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) throw ConfigError(path, "", "a YAML map of options (the file is empty)");
  if (text[first] != '%') text = "%YAML:1.0\n---\n" + text;
  try {
    // FORMAT_YAML: never guess XML or JSON from the content; this is a YAML file or an error.
    storage_.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    cv::utils::logging::setLogLevel(previous);
    std::string why = e.err.empty() ? e.what() : e.err;
    throw ConfigError(path, "", "a YAML file (" + why + ")");
  }
  cv::utils::logging::setLogLevel(previous);
  if (!storage_.isOpened()) throw ConfigError(path, "", "a YAML file that OpenCV can open");
  const cv::FileNode top = storage_.root();
  if (!top.isMap()) throw ConfigError(path, "", "a YAML map of options at the top level");
}

OptionsNode OptionsFile::root() { return OptionsNode(storage_.root(), path_, "", read_keys_); }

}  // namespace rsrio
