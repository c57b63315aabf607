// rsrio-devices: the TI radar boards on USB, with VID:PID, serial and bus path.
// Exit 0 when at least one board is present, 1 when none (or USB cannot be read), 2 on usage.
#include <cstdio>
#include <iostream>

#include "rsrio/common/cli.hpp"
#include "rsrio/driver/usb_devices.hpp"

int main(int argc, char** argv) {
  rsrio::Cli cli("rsrio-devices", "List the TI mmWave radar boards connected over USB.");
  if (auto rc = cli.parse(argc, argv)) return *rc;
  const rsrio::UsbListing listing = rsrio::list_ti_boards();
  if (!listing.error.empty()) {
    std::cerr << "rsrio-devices: " << listing.error << "\n";
    return 1;
  }
  if (listing.boards.empty()) {
    std::cout << "no TI radar boards found on USB (looked for";
    for (const auto& id : rsrio::kTiUsbIds) std::printf(" %04x:%04x", id.vid, id.pid);
    std::cout << ")\n";
    return 1;
  }
  bool denied = false;
  for (const auto& b : listing.boards) {
    std::printf("%04x:%04x  bus %-10s serial %-16s %s%s\n", b.vid, b.pid, b.bus_path.c_str(),
                b.serial.empty() ? "?" : b.serial.c_str(), b.what.c_str(), b.access_denied ? "  [access denied]" : "");
    denied |= b.access_denied;
  }
  if (denied)
    std::cout << "access denied: install systemd/99-rsrio-ti-radar.rules into /etc/udev/rules.d (cmake --install does),\n"
                 "add yourself to group plugdev, then: udevadm control --reload && udevadm trigger\n";
  return 0;
}
