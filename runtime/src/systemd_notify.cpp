#include "rsrio/runtime/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

namespace rsrio::systemd {

bool notify(const std::string& state) { return sd_notify(0, state.c_str()) > 0; }

std::chrono::microseconds watchdog_interval() {
  std::uint64_t usec = 0;
  return sd_watchdog_enabled(0, &usec) > 0 ? std::chrono::microseconds(usec) : std::chrono::microseconds(0);
}

}  // namespace rsrio::systemd
