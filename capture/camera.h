// Cameras and light rigs behind small interfaces, opened by URI (registry.h). Backends:
// v4l2/ (Linux cameras), usb/ (the matfit LED-rig protocol over libusb), sim/ (simulated
// devices that render a synthetic material). Hardware boundaries (ioctl, USB transfers) are
// interfaces too, so that every backend is tested here without hardware.
#pragma once

#include <string>
#include <vector>

#include "core/image.h"
#include "core/status.h"
#include "core/vec3.h"

namespace matfit::capture {

// Pixel formats a camera may deliver; all are converted to linear float by the backend.
enum class PixelFormat { kYuyv, kMjpeg, kGrey, kY16, kRgb24 };
const char* PixelFormatName(PixelFormat f);  // "YUYV", "MJPEG", "GREY", "Y16", "RGB24"
bool ParsePixelFormat(const std::string& name, PixelFormat* out);

struct FrameFormat {
  PixelFormat pixel_format = PixelFormat::kYuyv;
  int width = 0, height = 0;
};

struct CameraInfo {
  std::string uri, driver, name;
  std::vector<FrameFormat> formats;  // what the device offers
  bool manual_exposure = false, gain = false;
  double exposure_min_s = 0, exposure_max_s = 0;
};

class LightRig;

class Camera {
 public:
  virtual ~Camera() = default;
  virtual CameraInfo Info() const = 0;
  // Negotiates a format; the device may adjust the size (Format() tells what was granted).
  virtual Status SetFormat(const FrameFormat& f) = 0;
  virtual FrameFormat Format() const = 0;
  virtual Status SetExposure(double seconds) = 0;  // manual exposure
  virtual Status SetGain(double gain) = 0;         // ≥ 1, linear
  // One frame as linear float in [0, 1] of the sensor's full scale (1 or 3 channels); errors
  // for a timeout or a lost device name the device.
  virtual StatusOr<Image> Grab(int timeout_ms) = 0;
  virtual void Close() = 0;
  // Simulated cameras render what the rig lights; real cameras ignore this.
  virtual void AttachLightRig(LightRig*) {}
};

class LightRig {
 public:
  virtual ~LightRig() = default;
  virtual std::string Describe() const = 0;
  virtual int Count() const = 0;
  virtual Vec3 Direction(int led) const = 0;      // unit, toward the light (x right, y up, z out)
  virtual Status Set(int led, double level) = 0;  // level in [0, 1]
  virtual Status AllOff() = 0;
  virtual Status All(double level) = 0;
  virtual StatusOr<std::vector<double>> State() = 0;  // read back from the device
};

}  // namespace matfit::capture
