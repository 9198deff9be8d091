// What to render: scene, light, camera output and tone mapping (shared by the CPU and EGL
// backends, `matfit render` and the server's preview endpoint).
#pragma once

#include <string>

#include "core/status.h"
#include "core/vec3.h"

namespace matfit::render {

enum class Scene { kPlane, kSphere, kCloth };
enum class Tonemap { kClamp, kReinhard };

// "plane" | "sphere" | "cloth"; "clamp" | "reinhard".
StatusOr<Scene> ParseScene(const std::string& name);
StatusOr<Tonemap> ParseTonemap(const std::string& name);
const char* SceneName(Scene s);

struct RenderOptions {
  Scene scene = Scene::kPlane;
  int size = 256;             // output is size × size pixels, [8, 4096]
  double theta_deg = 30;      // light elevation from the surface normal (plane) / view axis
  double phi_deg = 45;        // light azimuth, counter-clockwise from image right
  Vec3 light_color{1, 1, 1};  // linear RGB, times intensity
  double intensity = 1;       // ≥ 0
  double ambient = 0;         // ≥ 0: ambient × albedo is added
  double exposure = 1;        // > 0, display output only
  Tonemap tonemap = Tonemap::kClamp;
  bool display = true;  // true: exposure, tone map, sRGB-encoded [0, 1]; false: linear radiance

  bool Check(std::string* why) const;
  // Unit direction toward the light in the world frame (x right, y up, z toward the camera).
  Vec3 LightDirection() const;
};

}  // namespace matfit::render
