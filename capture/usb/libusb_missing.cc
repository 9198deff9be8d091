// Built instead of libusb_transport.cc when libusb-1.0 is not found: the USB backend reports
// that it is disabled (the protocol and the rig logic are still built and tested).
#include "capture/usb/usb_transport.h"

namespace matfit::capture {

bool LibusbAvailable() { return false; }

StatusOr<std::unique_ptr<UsbTransport>> OpenLibusbTransport(uint16_t, uint16_t,
                                                            const std::string&) {
  return Status(StatusCode::kUnavailable,
                "this matfit was built without libusb-1.0 (install libusb-1.0-0-dev and rebuild)");
}

std::vector<std::string> ListLibusbRigs() { return {}; }

}  // namespace matfit::capture
