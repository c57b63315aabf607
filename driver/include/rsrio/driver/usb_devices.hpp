// TI radar boards on USB (libusb): discovery by VID:PID, and hotplug notification so the daemon
// notices an unplugged / replugged board. The radar data itself travels over Ethernet (DCA1000)
// or sits on the capture card (cascade); USB carries control (FTDI SPI/GPIO) and the EVM's UARTs.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rsrio {

struct TiUsbId {
  std::uint16_t vid;
  std::uint16_t pid;
  const char* what;
};

/// The boards we know (shared/reference/driver_dsp.md Sec. 5).
inline constexpr TiUsbId kTiUsbIds[] = {
    {0x0451, 0xFD03, "DCA1000EVM / MMWAVEICBOOST (FTDI FT4232H, TI IDs)"},
    {0x0451, 0xBEF3, "xWR EVM on-board XDS110 debug probe (CLI and data UARTs)"},
    {0x0403, 0x6011, "FTDI FT4232H (DCA1000EVM with FTDI's own IDs)"},
    {0x10C4, 0xEA70, "IWR6843ISK (Silicon Labs CP2105 dual UART)"},
};
/// The entry for a VID:PID, or nullptr.
const TiUsbId* find_ti_usb_id(std::uint16_t vid, std::uint16_t pid);

struct UsbBoard {
  std::uint16_t vid = 0, pid = 0;
  std::string what;
  std::string serial;      // empty when it could not be read
  std::string bus_path;    // "1-2.3": bus, then port numbers
  bool access_denied = false;  // found, but this user may not open it (udev rule missing?)
};

struct UsbListing {
  std::vector<UsbBoard> boards;
  std::string error;  // libusb could not start or enumerate (no USB, no /dev/bus/usb): say why
};

/// Lists the TI boards present. Never throws.
UsbListing list_ti_boards();

/// Calls back on arrival and departure of TI boards, from its own thread. Start it before
/// streaming; the callback must be quick (set a flag, push to a queue).
class UsbHotplugMonitor {
 public:
  enum class Event { kArrived, kLeft };
  using Callback = std::function<void(Event, const UsbBoard&)>;

  explicit UsbHotplugMonitor(Callback callback);
  ~UsbHotplugMonitor();
  UsbHotplugMonitor(const UsbHotplugMonitor&) = delete;
  UsbHotplugMonitor& operator=(const UsbHotplugMonitor&) = delete;

  /// False when this libusb/platform cannot do hotplug (then error() says why).
  bool active() const;
  const std::string& error() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsrio
