#include "capture/usb/usb_rig.h"

#include <cmath>
#include <cstdlib>

#include "capture/usb/protocol.h"

namespace matfit::capture {
namespace {

namespace rp = rigproto;

class UsbRig final : public LightRig {
 public:
  UsbRig(std::unique_ptr<UsbTransport> t, std::vector<Vec3> dirs, int count)
      : t_(std::move(t)), dirs_(std::move(dirs)), count_(count) {}

  std::string Describe() const override { return t_->Describe(); }
  int Count() const override { return count_; }
  Vec3 Direction(int led) const override { return dirs_[size_t(led)]; }

  Status Set(int led, double level) override {
    if (led < 0 || led >= count_)
      return InvalidArgument("LED " + std::to_string(led) + " does not exist; the rig has " +
                             std::to_string(count_));
    return Out(rp::kSetLed, Level(level), uint16_t(led), "set LED " + std::to_string(led));
  }
  Status AllOff() override { return Out(rp::kAllOff, 0, 0, "switch all LEDs off"); }
  Status All(double level) override { return Out(rp::kSetAll, Level(level), 0, "set all LEDs"); }

  StatusOr<std::vector<double>> State() override {
    std::vector<uint8_t> buf(size_t(2 * count_));
    const int r = t_->Control(rp::kRequestTypeIn, rp::kGetState, 0, 0, buf.data(),
                              uint16_t(buf.size()), rp::kTimeoutMs);
    if (r < 0) return Fail(r, "read the LED state");
    if (r != int(buf.size()))
      return DataError(Describe() + " answered GET_STATE with " + std::to_string(r) +
                       " bytes, expected " + std::to_string(buf.size()));
    std::vector<double> out(static_cast<size_t>(count_));
    for (int i = 0; i < count_; ++i)
      out[size_t(i)] = double(buf[size_t(2 * i)] | (buf[size_t(2 * i + 1)] << 8)) / 65535.0;
    return out;
  }

 private:
  static uint16_t Level(double v) {
    return uint16_t(std::lround(std::min(1.0, std::max(0.0, v)) * 65535.0));
  }
  Status Fail(int r, const std::string& what) const {
    switch (r) {
      case rp::kErrorNoDevice:
        return Status(StatusCode::kUnavailable, "light rig " + Describe() +
                                                    " was disconnected (could not " + what +
                                                    "); reconnect it and resume the capture");
      case rp::kErrorTimeout:
        return Status(StatusCode::kUnavailable,
                      "light rig " + Describe() + " did not answer within " +
                          std::to_string(rp::kTimeoutMs) + " ms (could not " + what + ")");
      case rp::kErrorPipe:
        return Status(StatusCode::kDataError,
                      "light rig " + Describe() + " refused the request (could not " + what + ")");
      default:
        return Status(StatusCode::kUnavailable, "light rig " + Describe() + ": USB error " +
                                                    std::to_string(r) + " (could not " + what +
                                                    ")");
    }
  }
  Status Out(uint8_t req, uint16_t value, uint16_t index, const std::string& what) {
    if (!t_->Connected()) return Fail(rp::kErrorNoDevice, what);
    const int r = t_->Control(rp::kRequestTypeOut, req, value, index, nullptr, 0, rp::kTimeoutMs);
    return r < 0 ? Fail(r, what) : Status::Ok();
  }

  std::unique_ptr<UsbTransport> t_;
  std::vector<Vec3> dirs_;
  int count_;
};

}  // namespace

StatusOr<std::unique_ptr<LightRig>> OpenUsbRig(std::unique_ptr<UsbTransport> t,
                                               std::vector<Vec3> directions) {
  uint8_t id[8] = {};
  const int r = t->Control(rp::kRequestTypeIn, rp::kIdentify, 0, 0, id, 8, rp::kTimeoutMs);
  const std::string dev = t->Describe();
  if (r == rp::kErrorTimeout)
    return Status(StatusCode::kUnavailable, "light rig " + dev + " did not answer IDENTIFY");
  if (r < 0)
    return Status(StatusCode::kUnavailable,
                  "light rig " + dev + ": IDENTIFY failed (USB error " + std::to_string(r) + ")");
  if (r != 8 || id[0] != 'M' || id[1] != 'F' || id[2] != 'L' || id[3] != 'R')
    return DataError("USB device " + dev +
                     " is not a matfit light rig (IDENTIFY did not return 'MFLR'); check the "
                     "VID:PID in the URI");
  if (id[4] != rp::kMajor)
    return DataError("light rig " + dev + " speaks protocol " + std::to_string(id[4]) + "." +
                     std::to_string(id[5]) + "; this matfit speaks " + std::to_string(rp::kMajor) +
                     ".x — update the firmware or matfit");
  const int count = id[6] | (id[7] << 8);
  if (count < 1) return DataError("light rig " + dev + " reports 0 LEDs");
  if (int(directions.size()) != count)
    return InvalidArgument("light rig " + dev + " has " + std::to_string(count) +
                           " LEDs but its calibration file gives " +
                           std::to_string(directions.size()) + " directions");
  return std::unique_ptr<LightRig>(new UsbRig(std::move(t), std::move(directions), count));
}

bool ParseUsbUri(const std::string& uri, uint16_t* vid, uint16_t* pid, std::string* serial) {
  if (uri.rfind("usb:", 0) != 0) return false;
  const std::string rest = uri.substr(4);
  const auto a = rest.find(':');
  if (a == std::string::npos) return false;
  const auto b = rest.find(':', a + 1);
  const std::string v = rest.substr(0, a),
                    p = rest.substr(a + 1, b == std::string::npos ? std::string::npos : b - a - 1);
  char* end = nullptr;
  const long lv = std::strtol(v.c_str(), &end, 16);
  if (v.empty() || *end || lv < 0 || lv > 0xffff) return false;
  const long lp = std::strtol(p.c_str(), &end, 16);
  if (p.empty() || *end || lp < 0 || lp > 0xffff) return false;
  *vid = uint16_t(lv), *pid = uint16_t(lp);
  *serial = b == std::string::npos ? "" : rest.substr(b + 1);
  return true;
}

}  // namespace matfit::capture
