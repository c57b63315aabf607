// USB discovery: the VID:PID table matches the udev rule we ship, and libusb really runs here
// (listing and hotplug registration), whether or not a board is plugged in.
#include "rsrio/driver/usb_devices.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

#include <catch2/catch_test_macros.hpp>

TEST_CASE("every known board has a line in the shipped udev rule", "[usb]") {
  std::ifstream f("systemd/99-rsrio-ti-radar.rules");
  REQUIRE(f.good());
  std::stringstream s;
  s << f.rdbuf();
  for (const auto& id : rsrio::kTiUsbIds) {
    if (id.vid == 0x10C4) continue;  // CP2105 ISK boards: serial only, no rsrio use yet
    char vid[8], pid[8];
    std::snprintf(vid, sizeof vid, "%04x", id.vid);
    std::snprintf(pid, sizeof pid, "%04x", id.pid);
    INFO(vid << ":" << pid);
    CHECK(s.str().find("ATTRS{idVendor}==\"" + std::string(vid) + "\", ATTRS{idProduct}==\"" + pid + "\"") !=
          std::string::npos);
  }
  CHECK(rsrio::find_ti_usb_id(0x0451, 0xFD03) != nullptr);
  CHECK(rsrio::find_ti_usb_id(0x0451, 0x0001) == nullptr);
}

TEST_CASE("libusb lists what is there without failing", "[usb]") {
  const auto listing = rsrio::list_ti_boards();
  INFO(listing.error);
  for (const auto& b : listing.boards) {
    CHECK(rsrio::find_ti_usb_id(b.vid, b.pid) != nullptr);
    CHECK(!b.bus_path.empty());
  }
  rsrio::UsbHotplugMonitor monitor([](rsrio::UsbHotplugMonitor::Event, const rsrio::UsbBoard&) {});
  INFO(monitor.error());
  // Linux libusb has hotplug; it registers even with no USB bus present.
  CHECK((monitor.active() || !monitor.error().empty()));
}
