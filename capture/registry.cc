#include "capture/registry.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "capture/sim/sim_devices.h"
#include "capture/usb/usb_rig.h"
#include "capture/usb/usb_transport.h"
#ifdef MATFIT_HAVE_V4L2
#include "capture/v4l2/v4l2_camera.h"
#endif

namespace matfit::capture {

StatusOr<std::unique_ptr<Camera>> OpenCamera(const std::string& uri) {
  if (uri.rfind("v4l2:", 0) == 0) {
#ifdef MATFIT_HAVE_V4L2
    return OpenV4l2Camera(uri.substr(5), SystemV4l2Io());
#else
    return Status(StatusCode::kUnavailable, "this matfit was built without the V4L2 backend");
#endif
  }
  if (uri.rfind("sim:camera", 0) == 0) return OpenSimCamera(uri);
  return InvalidArgument("camera URI '" + uri +
                         "' has an unknown scheme; use v4l2:/dev/videoN or sim:camera?…");
}

StatusOr<std::unique_ptr<LightRig>> OpenLightRig(const std::string& uri,
                                                 const std::string& lights_file) {
  if (uri.rfind("sim:rig", 0) == 0) return OpenSimRig(uri);
  if (uri.rfind("usb:", 0) == 0) {
    uint16_t vid, pid;
    std::string serial;
    if (!ParseUsbUri(uri, &vid, &pid, &serial))
      return InvalidArgument("light rig URI '" + uri + "' must be usb:VID:PID[:SERIAL] (hex)");
    if (lights_file.empty())
      return InvalidArgument("light rig " + uri +
                             " needs its calibration file (--rig-lights FILE: .lp or lights.txt)");
    auto dirs = ReadLightDirections(lights_file);
    if (!dirs.ok()) return dirs.status();
    auto t = OpenLibusbTransport(vid, pid, serial);
    if (!t.ok()) return t.status();
    return OpenUsbRig(std::move(*t), std::move(*dirs));
  }
  return InvalidArgument("light rig URI '" + uri +
                         "' has an unknown scheme; use usb:VID:PID[:SERIAL] or sim:rig?…");
}

StatusOr<std::vector<Vec3>> ReadLightDirections(const std::string& path) {
  std::ifstream in(path);
  if (!in) return NotFound("cannot open light file '" + path + "'");
  std::string line;
  int number = 0, count = -1;
  std::vector<Vec3> out;
  while (std::getline(in, line)) {
    ++number;
    std::istringstream s(line);
    std::vector<std::string> tok;
    for (std::string t; s >> t;) tok.push_back(t);
    if (tok.empty() || tok[0][0] == '#') continue;
    if (count < 0) {
      count = std::atoi(tok[0].c_str());
      if (tok.size() != 1 || count <= 0)
        return DataError(path + ":" + std::to_string(number) + ": expected the light count");
      continue;
    }
    if (tok.size() != 3 && tok.size() != 4)
      return DataError(path + ":" + std::to_string(number) + ": expected `x y z` or `name x y z`");
    const size_t o = tok.size() - 3;
    Vec3 d{std::strtod(tok[o].c_str(), nullptr), std::strtod(tok[o + 1].c_str(), nullptr),
           std::strtod(tok[o + 2].c_str(), nullptr)};
    const double len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    if (!(len > 1e-9) || !std::isfinite(len))
      return DataError(path + ":" + std::to_string(number) +
                       ": the direction is zero or not finite");
    out.push_back({d.x / len, d.y / len, d.z / len});
  }
  if (count < 0) return DataError("light file '" + path + "' is empty");
  if (int(out.size()) != count)
    return DataError("light file '" + path + "' announces " + std::to_string(count) +
                     " lights but lists " + std::to_string(out.size()));
  return out;
}

std::vector<std::string> ListDevices() {
  std::vector<std::string> out;
#ifdef MATFIT_HAVE_V4L2
  auto io = SystemV4l2Io();
  for (const auto& c : ListV4l2Cameras(*io)) out.push_back("camera    " + c);
#else
  out.push_back("camera    (V4L2 backend not built)");
#endif
  if (LibusbAvailable())
    for (const auto& r : ListLibusbRigs()) out.push_back("light rig " + r);
  else
    out.push_back("light rig (USB backend not built: libusb-1.0 was not found)");
  out.push_back("camera    sim:camera?material=plaster&size=64 (simulated)");
  out.push_back("light rig sim:rig?lights=bonn81 (simulated)");
  return out;
}

}  // namespace matfit::capture
