// The matfit LED-rig USB protocol, version 1.0 (docs/capture.md). Vendor control transfers on
// interface 0; multi-byte values little-endian; LED levels 0..65535 (linear PWM duty).
//
//   request            dir  wValue   wIndex  data
//   0x01 IDENTIFY      IN   0        0       8 bytes: 'M' 'F' 'L' 'R', major, minor, count (u16)
//   0x02 SET_LED       OUT  level    led     —
//   0x03 ALL_OFF       OUT  0        0       —
//   0x04 GET_STATE     IN   0        0       2 × count bytes: the level of every LED
//   0x05 SET_ALL       OUT  level    0       —
//
// A device whose major version differs is refused; minor versions only add requests.
#pragma once

#include <cstdint>

namespace matfit::capture::rigproto {

constexpr uint16_t kDefaultVendorId = 0x1209;   // pid.codes open-hardware vendor id
constexpr uint16_t kDefaultProductId = 0x4d46;  // "MF"
constexpr uint8_t kMajor = 1, kMinor = 0;
constexpr uint8_t kRequestTypeIn = 0xC1;   // device-to-host | vendor | interface
constexpr uint8_t kRequestTypeOut = 0x41;  // host-to-device | vendor | interface
enum Request : uint8_t { kIdentify = 1, kSetLed = 2, kAllOff = 3, kGetState = 4, kSetAll = 5 };
constexpr unsigned kTimeoutMs = 500;

// Transfer results below zero (libusb's values, so the fake and the real transport agree).
enum Error : int {
  kErrorIo = -1,
  kErrorNoDevice = -4,
  kErrorBusy = -6,
  kErrorTimeout = -7,
  kErrorPipe = -9,  // the device stalled the request (unknown request or bad argument)
};

}  // namespace matfit::capture::rigproto
