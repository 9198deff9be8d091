// V4L2 camera: capability query, format negotiation (YUYV, MJPEG, GREY, Y16, RGB24), mmap
// streaming with a small buffer queue, manual exposure and gain controls, frame timeout, and
// device-lost handling. URI: `v4l2:/dev/videoN`.
#pragma once

#include <memory>
#include <string>

#include "capture/camera.h"
#include "capture/v4l2/v4l2_io.h"

namespace matfit::capture {

// Opens the device through `io` (SystemV4l2Io() for real hardware). Errors name the device and
// say what to do: absent ("no such device; `matfit devices` lists cameras"), busy ("in use by
// another program"), not a capture device, no supported format.
StatusOr<std::unique_ptr<Camera>> OpenV4l2Camera(const std::string& path,
                                                 std::unique_ptr<V4l2Io> io, int buffers = 4);

// /dev/video* nodes that answer VIDIOC_QUERYCAP as capture devices ("v4l2:/dev/video0 (name)").
std::vector<std::string> ListV4l2Cameras(V4l2Io& io);

}  // namespace matfit::capture
