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
  // Orthographic camera: view direction (toward the camera) at elevation θ_c ∈ [0, 80] from the
  // sample normal, azimuth φ_c; 0, 0 looks straight down. The view spans [−1, 1]² in camera units.
  double camera_theta_deg = 0, camera_phi_deg = 0;

  bool Check(std::string* why) const;
  // Unit direction toward the light in the world frame (x right, y up, z toward the camera).
  Vec3 LightDirection() const;
};

// Camera frame: v toward the camera, r image right, u image up (r = x, u = y at θ_c = 0 for any
// φ_c), as float so that every backend uses the same values.
struct CameraFrame {
  Vec3f v{0, 0, 1}, r{1, 0, 0}, u{0, 1, 0};
};
CameraFrame MakeCamera(double theta_deg, double phi_deg);

}  // namespace matfit::render
