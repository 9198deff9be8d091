#include "render/render_options.h"

#include <cmath>

namespace matfit::render {

StatusOr<Scene> ParseScene(const std::string& name) {
  if (name == "plane") return Scene::kPlane;
  if (name == "sphere") return Scene::kSphere;
  if (name == "cloth") return Scene::kCloth;
  return InvalidArgument("unknown scene '" + name + "'; choose one of: plane, sphere, cloth");
}

StatusOr<Tonemap> ParseTonemap(const std::string& name) {
  if (name == "clamp") return Tonemap::kClamp;
  if (name == "reinhard") return Tonemap::kReinhard;
  return InvalidArgument("unknown tone map '" + name + "'; choose one of: clamp, reinhard");
}

const char* SceneName(Scene s) {
  switch (s) {
    case Scene::kPlane: return "plane";
    case Scene::kSphere: return "sphere";
    case Scene::kCloth: return "cloth";
  }
  return "?";
}

bool RenderOptions::Check(std::string* why) const {
  if (size < 8 || size > 4096) {
    *why = "--size must be in [8, 4096], got " + std::to_string(size);
    return false;
  }
  if (!(theta_deg >= 0 && theta_deg <= 180) || !std::isfinite(phi_deg)) {
    *why = "--light THETA,PHI: θ must be in [0, 180] degrees and φ finite, got " +
           std::to_string(theta_deg) + "," + std::to_string(phi_deg);
    return false;
  }
  if (!(intensity >= 0) || !(ambient >= 0) || !(exposure > 0) || !std::isfinite(intensity) ||
      !std::isfinite(ambient) || !std::isfinite(exposure)) {
    *why = "--intensity and --ambient must be ≥ 0 and --exposure > 0 (finite), got " +
           std::to_string(intensity) + ", " + std::to_string(ambient) + ", " +
           std::to_string(exposure);
    return false;
  }
  if (!(camera_theta_deg >= 0 && camera_theta_deg <= 80) || !std::isfinite(camera_phi_deg)) {
    *why = "--camera THETA,PHI: θ must be in [0, 80] degrees and φ finite, got " +
           std::to_string(camera_theta_deg) + "," + std::to_string(camera_phi_deg);
    return false;
  }
  return true;
}

CameraFrame MakeCamera(double theta_deg, double phi_deg) {
  const double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
  const double ct = std::cos(t), st = std::sin(t), cp = std::cos(p), sp = std::sin(p);
  const Vec3 v(st * cp, st * sp, ct), et(ct * cp, ct * sp, -st), ep(-sp, cp, 0);
  CameraFrame c;
  c.v = Vec3f(v);
  c.r = Vec3f(et * cp - ep * sp);
  c.u = Vec3f(et * sp + ep * cp);
  return c;
}

Vec3 RenderOptions::LightDirection() const {
  const double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

}  // namespace matfit::render
