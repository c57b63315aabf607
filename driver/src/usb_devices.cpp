#include "rsrio/driver/usb_devices.hpp"

#include <atomic>
#include <thread>

#include <libusb.h>

namespace rsrio {

namespace {

std::string bus_path(libusb_device* dev) {
  std::string path = std::to_string(libusb_get_bus_number(dev));
  std::uint8_t ports[8];
  const int n = libusb_get_port_numbers(dev, ports, 8);
  for (int i = 0; i < n; ++i) path += (i == 0 ? "-" : ".") + std::to_string(ports[i]);
  return path;
}

std::optional<UsbBoard> describe(libusb_device* dev) {
  libusb_device_descriptor d{};
  if (libusb_get_device_descriptor(dev, &d) != 0) return std::nullopt;
  const TiUsbId* id = find_ti_usb_id(d.idVendor, d.idProduct);
  if (!id) return std::nullopt;
  UsbBoard b;
  b.vid = d.idVendor;
  b.pid = d.idProduct;
  b.what = id->what;
  b.bus_path = bus_path(dev);
  libusb_device_handle* h = nullptr;
  const int rc = libusb_open(dev, &h);
  if (rc == LIBUSB_ERROR_ACCESS) {
    b.access_denied = true;
  } else if (rc == 0) {
    unsigned char serial[128] = {};
    if (d.iSerialNumber && libusb_get_string_descriptor_ascii(h, d.iSerialNumber, serial, sizeof serial) > 0)
      b.serial = reinterpret_cast<char*>(serial);
    libusb_close(h);
  }
  return b;
}

}  // namespace

const TiUsbId* find_ti_usb_id(std::uint16_t vid, std::uint16_t pid) {
  for (const auto& id : kTiUsbIds)
    if (id.vid == vid && id.pid == pid) return &id;
  return nullptr;
}

UsbListing list_ti_boards() {
  UsbListing out;
  libusb_context* ctx = nullptr;
  if (const int rc = libusb_init(&ctx); rc != 0) {
    out.error = std::string("libusb could not start: ") + libusb_strerror(rc);
    return out;
  }
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx, &list);
  if (n < 0) {
    out.error = std::string("libusb could not list devices: ") + libusb_strerror(static_cast<int>(n));
  } else {
    for (ssize_t i = 0; i < n; ++i)
      if (auto b = describe(list[i])) out.boards.push_back(*b);
    libusb_free_device_list(list, 1);
  }
  libusb_exit(ctx);
  return out;
}

struct UsbHotplugMonitor::Impl {
  Callback callback;
  libusb_context* ctx = nullptr;
  libusb_hotplug_callback_handle handle = 0;
  bool registered = false;
  std::atomic<bool> stop{false};
  std::thread thread;
  std::string error;

  static int LIBUSB_CALL on_event(libusb_context*, libusb_device* dev, libusb_hotplug_event event, void* user) {
    auto* self = static_cast<Impl*>(user);
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(dev, &d) != 0) return 0;
    const TiUsbId* id = find_ti_usb_id(d.idVendor, d.idProduct);
    if (!id) return 0;
    UsbBoard b{d.idVendor, d.idProduct, id->what, "", bus_path(dev), false};
    self->callback(event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED ? Event::kArrived : Event::kLeft, b);
    return 0;  // stay registered
  }
};

UsbHotplugMonitor::UsbHotplugMonitor(Callback callback) : impl_(std::make_unique<Impl>()) {
  impl_->callback = std::move(callback);
  if (const int rc = libusb_init(&impl_->ctx); rc != 0) {
    impl_->error = std::string("libusb could not start: ") + libusb_strerror(rc);
    impl_->ctx = nullptr;
    return;
  }
  if (!libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) {
    impl_->error = "this libusb has no hotplug support";
    return;
  }
  const int rc = libusb_hotplug_register_callback(
      impl_->ctx,
      static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
      LIBUSB_HOTPLUG_NO_FLAGS, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
      &Impl::on_event, impl_.get(), &impl_->handle);
  if (rc != 0) {
    impl_->error = std::string("libusb hotplug registration failed: ") + libusb_strerror(rc);
    return;
  }
  impl_->registered = true;
  impl_->thread = std::thread([impl = impl_.get()] {
    while (!impl->stop) {
      timeval tv{0, 100'000};  // wake up to notice stop
      libusb_handle_events_timeout_completed(impl->ctx, &tv, nullptr);
    }
  });
}

UsbHotplugMonitor::~UsbHotplugMonitor() {
  impl_->stop = true;
  if (impl_->registered) libusb_hotplug_deregister_callback(impl_->ctx, impl_->handle);  // wakes the event loop
  if (impl_->thread.joinable()) impl_->thread.join();
  if (impl_->ctx) libusb_exit(impl_->ctx);
}

bool UsbHotplugMonitor::active() const { return impl_->registered; }
const std::string& UsbHotplugMonitor::error() const { return impl_->error; }

}  // namespace rsrio
