#include "rsrio/common/log.hpp"

#include <array>
#include <string_view>

#include <spdlog/sinks/stdout_color_sinks.h>

namespace rsrio {

namespace {
constexpr std::array<std::string_view, 7> kLevels = {"trace", "debug", "info", "warn", "error", "critical", "off"};
}

bool is_log_level(const std::string& level) {
  for (auto l : kLevels)
    if (l == level) return true;
  return false;
}

void setup_logging(const std::string& program, const std::string& level) {
  auto logger = spdlog::stderr_color_mt(program);
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [%n] %v");
  logger->set_level(spdlog::level::from_str(level));
  spdlog::set_default_logger(logger);
}

}  // namespace rsrio
