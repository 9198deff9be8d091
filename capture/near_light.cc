#include "capture/near_light.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Dense>

namespace matfit::capture {

SphereRay RayFromSphere(const SphereFit& s, int width, int height, const Vec3& mirror) {
  // Pixel (x, y)'s centre is at (x, y) in SphereFit and at (x + ½ − W/2, H/2 − y − ½) here.
  const Vec3 c(s.cx + 0.5 - 0.5 * width, 0.5 * height - s.cy - 0.5, s.radius);
  const Vec3 r = Normalize(mirror);
  const Vec3 n = Normalize(r + Vec3(0, 0, 1));
  return {c + n * s.radius, r};
}

StatusOr<TriangulatedLight> TriangulateLight(const std::vector<SphereRay>& rays,
                                             double min_angle_deg) {
  if (rays.size() < 2) return InvalidArgument("a light's position needs two or more spheres");
  TriangulatedLight out;
  for (size_t i = 0; i < rays.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      out.angle = std::max(out.angle, AngleDeg(rays[i].direction, rays[j].direction));
  if (out.angle < min_angle_deg)
    return DataError("the spheres see the light within " + std::to_string(out.angle) +
                     "° of each other: too far away to place from these spheres (move them "
                     "apart, or treat the lights as distant)");
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const SphereRay& r : rays) {
    const Eigen::Vector3d d(r.direction.x, r.direction.y, r.direction.z),
        x(r.origin.x, r.origin.y, r.origin.z);
    const Eigen::Matrix3d m = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += m, b += m * x;
  }
  const Eigen::Vector3d p = a.ldlt().solve(b);
  out.position = Vec3(p.x(), p.y(), p.z());
  double ss = 0;
  out.min_t = INFINITY;
  for (const SphereRay& r : rays) {
    const Vec3 q = out.position - r.origin;
    const double t = Dot(q, r.direction);
    const Vec3 perp = q - r.direction * t;
    ss += Dot(perp, perp);
    out.min_t = std::min(out.min_t, t);
  }
  out.rms = std::sqrt(ss / double(rays.size()));
  if (out.min_t <= 0)
    return DataError(
        "the spheres' rays meet behind a sphere: the highlights do not come from "
        "one near light (check the spheres' order and the photos)");
  return out;
}

}  // namespace matfit::capture
