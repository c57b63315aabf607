// Number arguments of the programs' command lines: the whole text must be the number.
#pragma once

#include <cmath>
#include <cstdint>
#include <exception>
#include <string>

namespace rsrio::tools {

inline bool parse_double(const std::string& text, double& out) {
  try {
    std::size_t used = 0;
    out = std::stod(text, &used);
    return used == text.size() && std::isfinite(out);
  } catch (const std::exception&) {
    return false;
  }
}

inline bool parse_u64(const std::string& text, std::uint64_t& out) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) return false;
  try {
    out = std::stoull(text);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

/// A probability in [0, 1].
inline bool parse_probability(const std::string& text, double& out) {
  return parse_double(text, out) && out >= 0.0 && out <= 1.0;
}

}  // namespace rsrio::tools
