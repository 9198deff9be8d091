// Opening devices by URI: the scheme picks the backend.
//   v4l2:/dev/videoN                 V4L2 camera (Linux)
//   usb:VID:PID[:SERIAL]             matfit LED rig over USB (directions from a lights file)
//   sim:camera?…  sim:rig?…          simulated devices (sim/sim_devices.h)
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "capture/camera.h"

namespace matfit::capture {

StatusOr<std::unique_ptr<Camera>> OpenCamera(const std::string& uri);
// lights_file: the rig's calibration (.lp or lights.txt), required for usb: rigs.
StatusOr<std::unique_ptr<LightRig>> OpenLightRig(const std::string& uri,
                                                 const std::string& lights_file);
// Light directions of a calibration file (.lp: `N` then `name x y z`; lights.txt: `N` then
// `x y z`), normalised. Errors name the file and line.
StatusOr<std::vector<Vec3>> ReadLightDirections(const std::string& path);

// What is connected, one line each, plus the backends that are compiled out.
std::vector<std::string> ListDevices();

}  // namespace matfit::capture
