// The USB boundary of the light-rig backend: control transfers only. The real transport is
// libusb (libusb_transport.cc); tests put a fake firmware behind this interface.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/status.h"

namespace matfit::capture {

class UsbTransport {
 public:
  virtual ~UsbTransport() = default;
  // Bytes transferred (≥ 0) or a negative rigproto::Error.
  virtual int Control(uint8_t request_type, uint8_t request, uint16_t value, uint16_t index,
                      uint8_t* data, uint16_t length, unsigned timeout_ms) = 0;
  // True while the device is attached (a hotplug "left" event clears it).
  virtual bool Connected() = 0;
  virtual std::string Describe() const = 0;  // "usb:1209:4d46[:SERIAL]" (stable across re-plugs)
};

// Opens the first device with vid:pid (and serial, when not empty) and claims interface 0.
StatusOr<std::unique_ptr<UsbTransport>> OpenLibusbTransport(uint16_t vid, uint16_t pid,
                                                            const std::string& serial);
// Attached devices with the protocol's default vid:pid, as "usb:VID:PID:SERIAL".
std::vector<std::string> ListLibusbRigs();
bool LibusbAvailable();

}  // namespace matfit::capture
