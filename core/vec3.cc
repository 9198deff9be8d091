#include "core/vec3.h"

#include <algorithm>
#include <numbers>

namespace matfit {

namespace {
constexpr double kDeg = std::numbers::pi / 180.0;
}

Vec3 DirectionFromAnglesDeg(double theta_deg, double phi_deg) {
  const double t = theta_deg * kDeg, p = phi_deg * kDeg;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

void AnglesDegFromDirection(const Vec3& d, double* theta_deg, double* phi_deg) {
  const Vec3 u = Normalize(d);
  *theta_deg = std::acos(std::clamp(u.z, -1.0, 1.0)) / kDeg;
  double phi = std::atan2(u.y, u.x) / kDeg;
  if (phi < 0) phi += 360.0;
  if (phi >= 360.0) phi -= 360.0;
  *phi_deg = phi;
}

double AngleBetweenDeg(const Vec3& a, const Vec3& b) {
  const double c = Dot(Normalize(a), Normalize(b));
  return std::acos(std::clamp(c, -1.0, 1.0)) / kDeg;
}

}  // namespace matfit
