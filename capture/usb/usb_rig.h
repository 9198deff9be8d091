// LightRig over the matfit LED-rig USB protocol (protocol.h). URI: `usb:VID:PID[:SERIAL]`
// (hex ids). LED directions come from the rig's calibration file (a .lp or lights.txt).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "capture/camera.h"
#include "capture/usb/usb_transport.h"

namespace matfit::capture {

// Identifies the device (magic, major version, LED count); `directions` must have one entry
// per LED. Errors name the device: not a matfit rig, protocol version, count mismatch, timeout,
// disconnected.
StatusOr<std::unique_ptr<LightRig>> OpenUsbRig(std::unique_ptr<UsbTransport> transport,
                                               std::vector<Vec3> directions);

// Parses "usb:VID:PID[:SERIAL]".
bool ParseUsbUri(const std::string& uri, uint16_t* vid, uint16_t* pid, std::string* serial);

}  // namespace matfit::capture
