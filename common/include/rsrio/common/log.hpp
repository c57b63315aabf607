// Logging with spdlog: one stderr logger for the process (journald picks stderr up under
// systemd). Not for real-time threads: spdlog takes locks; those threads hand events to a queue.
#pragma once

#include <string>

#include <spdlog/spdlog.h>

namespace rsrio {

/// Whether `level` names a log level (trace, debug, info, warn, error, critical, off).
bool is_log_level(const std::string& level);

/// Sets up the process logger at `level` (must satisfy is_log_level).
void setup_logging(const std::string& program, const std::string& level);

}  // namespace rsrio
