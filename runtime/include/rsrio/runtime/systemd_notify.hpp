// systemd readiness and watchdog (sd_notify(3) through libsystemd). Outside systemd (no
// NOTIFY_SOCKET) every call is a harmless no-op.
#pragma once

#include <chrono>
#include <string>

namespace rsrio::systemd {

/// Sends a state line such as "READY=1" or "STATUS=streaming". True when systemd got it.
bool notify(const std::string& state);
inline bool ready() { return notify("READY=1"); }
inline bool stopping() { return notify("STOPPING=1"); }
inline bool watchdog() { return notify("WATCHDOG=1"); }
/// The watchdog interval systemd expects (WatchdogSec=), or zero when there is none. Ping at half.
std::chrono::microseconds watchdog_interval();

}  // namespace rsrio::systemd
