// UsbTransport over libusb-1.0: open by vid:pid[:serial], claim interface 0, control transfers;
// a hotplug "left" callback (where libusb supports hotplug) marks the device disconnected.
#include <libusb-1.0/libusb.h>

#include <atomic>
#include <cstdio>
#include <thread>

#include "capture/usb/protocol.h"
#include "capture/usb/usb_transport.h"

namespace matfit::capture {
namespace {

std::string Hex4(uint16_t v) {
  char b[8];
  std::snprintf(b, sizeof b, "%04x", v);
  return b;
}

std::string SerialOf(libusb_device_handle* h, const libusb_device_descriptor& d) {
  unsigned char s[128] = {};
  if (d.iSerialNumber == 0) return "";
  const int n = libusb_get_string_descriptor_ascii(h, d.iSerialNumber, s, sizeof s);
  return n > 0 ? std::string(reinterpret_cast<char*>(s), size_t(n)) : "";
}

class LibusbTransport final : public UsbTransport {
 public:
  LibusbTransport(libusb_context* ctx, libusb_device_handle* h, std::string desc)
      : ctx_(ctx), h_(h), desc_(std::move(desc)) {
    if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) {
      libusb_device_descriptor d{};
      libusb_get_device_descriptor(libusb_get_device(h_), &d);
      libusb_hotplug_register_callback(
          ctx_, LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT, LIBUSB_HOTPLUG_NO_FLAGS, d.idVendor, d.idProduct,
          LIBUSB_HOTPLUG_MATCH_ANY, &LibusbTransport::OnLeft, this, &hotplug_);
      events_ = std::thread([this] {
        while (!stop_) {
          timeval tv{0, 200000};
          libusb_handle_events_timeout_completed(ctx_, &tv, nullptr);
        }
      });
    }
  }
  ~LibusbTransport() override {
    stop_ = true;
    if (events_.joinable()) {
      libusb_hotplug_deregister_callback(ctx_, hotplug_);
      events_.join();
    }
    libusb_release_interface(h_, 0);
    libusb_close(h_);
    libusb_exit(ctx_);
  }
  int Control(uint8_t type, uint8_t req, uint16_t value, uint16_t index, uint8_t* data,
              uint16_t length, unsigned timeout_ms) override {
    if (!connected_) return rigproto::kErrorNoDevice;
    const int r = libusb_control_transfer(h_, type, req, value, index, data, length, timeout_ms);
    if (r == LIBUSB_ERROR_NO_DEVICE) connected_ = false;
    return r;
  }
  bool Connected() override { return connected_; }
  std::string Describe() const override { return desc_; }

 private:
  static int LIBUSB_CALL OnLeft(libusb_context*, libusb_device* dev, libusb_hotplug_event,
                                void* self) {
    auto* t = static_cast<LibusbTransport*>(self);
    if (dev == libusb_get_device(t->h_)) t->connected_ = false;
    return 0;
  }
  libusb_context* ctx_;
  libusb_device_handle* h_;
  std::string desc_;
  libusb_hotplug_callback_handle hotplug_ = 0;
  std::atomic<bool> connected_{true}, stop_{false};
  std::thread events_;
};

}  // namespace

bool LibusbAvailable() { return true; }

StatusOr<std::unique_ptr<UsbTransport>> OpenLibusbTransport(uint16_t vid, uint16_t pid,
                                                            const std::string& serial) {
  const std::string uri =
      "usb:" + Hex4(vid) + ":" + Hex4(pid) + (serial.empty() ? "" : ":" + serial);
  libusb_context* ctx = nullptr;
  if (libusb_init(&ctx) != 0)
    return Status(StatusCode::kUnavailable, "light rig " + uri + ": libusb cannot start");
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx, &list);
  libusb_device_handle* found = nullptr;
  std::string why = "no such device is attached; `matfit devices` lists what is";
  for (ssize_t i = 0; i < n && !found; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) != 0 || d.idVendor != vid || d.idProduct != pid)
      continue;
    libusb_device_handle* h = nullptr;
    const int r = libusb_open(list[i], &h);
    if (r != 0) {
      why = r == LIBUSB_ERROR_ACCESS
                ? "permission denied; add a udev rule for the rig (docs/capture.md)"
                : std::string("cannot open it: ") + libusb_strerror(r);
      continue;
    }
    if (!serial.empty() && SerialOf(h, d) != serial) {
      libusb_close(h);
      continue;
    }
    libusb_set_auto_detach_kernel_driver(h, 1);
    const int c = libusb_claim_interface(h, 0);
    if (c != 0) {
      why = c == LIBUSB_ERROR_BUSY ? "busy: another program has claimed it"
                                   : std::string("cannot claim interface 0: ") + libusb_strerror(c);
      libusb_close(h);
      continue;
    }
    found = h;
  }
  if (list) libusb_free_device_list(list, 1);
  if (!found) {
    libusb_exit(ctx);
    return Status(StatusCode::kNotFound, "light rig " + uri + ": " + why);
  }
  // The identity is vid:pid[:serial] only: a re-plugged rig gets a new bus address but is the
  // same rig (a capture resumes with it).
  return std::unique_ptr<UsbTransport>(new LibusbTransport(ctx, found, uri));
}

std::vector<std::string> ListLibusbRigs() {
  std::vector<std::string> out;
  libusb_context* ctx = nullptr;
  if (libusb_init(&ctx) != 0) return out;
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx, &list);
  for (ssize_t i = 0; i < n; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
    if (d.idVendor != rigproto::kDefaultVendorId || d.idProduct != rigproto::kDefaultProductId)
      continue;
    std::string serial;
    libusb_device_handle* h = nullptr;
    if (libusb_open(list[i], &h) == 0) {
      serial = SerialOf(h, d);
      libusb_close(h);
    }
    out.push_back("usb:" + Hex4(d.idVendor) + ":" + Hex4(d.idProduct) +
                  (serial.empty() ? "" : ":" + serial));
  }
  if (list) libusb_free_device_list(list, 1);
  libusb_exit(ctx);
  return out;
}

}  // namespace matfit::capture
