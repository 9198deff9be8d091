// Simulated camera and light rig: the camera renders a synthetic material (core/synth) with
// the shared CPU shading under whatever the rig lights, through a sensor model — exposure and
// gain scale the signal, shot and read noise, a black level, vignetting, saturation at full
// scale and quantisation to the pixel format (converted back exactly as a real frame is).
//
// URIs (query parameters optional):
//   sim:rig?lights=bonn81                       any light set of `matfit synth --lights`
//   sim:camera?material=plaster&size=64&seed=1&format=Y16&full_well=20000&read_noise=0.0005
//              &black=0.004&vignette=0.15&sensitivity=10&fail_after=-1&stale=0
// sensitivity: full-scale fraction per unit radiance and second (exposure 0.1 s, radiance 1 →
// 1.0 = saturation). fail_after=N: the N+1-th grab reports the device lost (tests).
#pragma once

#include <map>
#include <memory>
#include <string>

#include "capture/camera.h"
#include "core/material_maps.h"

namespace matfit::capture {

// "key=value&key=value" after a '?' (empty when none); *base receives the part before '?'.
std::map<std::string, std::string> ParseUriQuery(const std::string& uri, std::string* base);

StatusOr<std::unique_ptr<LightRig>> OpenSimRig(const std::string& uri);
StatusOr<std::unique_ptr<Camera>> OpenSimCamera(const std::string& uri);

// The simulated camera's ground truth for a capture (normals, and albedo in the units the
// capture measures: × sensitivity × mean vignetting when flat-fielded, × vignetting if not).
// Null for other cameras.
const MaterialMaps* SimCameraTruth(const Camera& camera, bool flat_fielded, MaterialMaps* out);

}  // namespace matfit::capture
