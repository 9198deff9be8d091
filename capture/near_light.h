// Near-light positions from two or more mirror spheres in the same photos (compute only).
//
// Frame (as light_positions.txt, docs/formats.md): x right, y up, z toward the camera, origin at
// the image centre, one unit per pixel; orthographic camera, view v = (0, 0, 1). A sphere seen
// at (cx, cy) (pixel centres at integers) with radius r that rests on the sample plane has its
// centre at C = (cx + ½ − W/2, H/2 − cy − ½, r). Its highlight's mirror direction R (EstimateLight)
// is reflected at X = C + r·n with n = (R + v)/|R + v|, and the light lies on the ray X + t·R, t >
// 0. The light is the point nearest to all rays in least squares:
//   Σ_k (I − R_k R_kᵀ) P = Σ_k (I − R_k R_kᵀ) X_k.
#pragma once

#include <vector>

#include "capture/calibrate.h"
#include "core/status.h"
#include "core/vec3.h"

namespace matfit::capture {

struct SphereRay {
  Vec3 origin;     // X: where the sphere reflects the light (frame units)
  Vec3 direction;  // R: unit, toward the light
};

// The ray of a sphere (seen at `s` in a width × height photo) whose highlight reflects along
// `mirror`.
SphereRay RayFromSphere(const SphereFit& s, int width, int height, const Vec3& mirror);

struct TriangulatedLight {
  Vec3 position;
  double rms = 0;    // distance of the point from the rays, root mean square (frame units)
  double angle = 0;  // the widest angle between two rays (degrees): the triangulation's baseline
  double min_t = 0;  // nearest distance along a ray (negative: behind a sphere)
};

// The least-squares point of ≥ 2 rays. Fails (naming why) when the rays are (nearly) parallel —
// the light is too far for these spheres to place it: widest angle under `min_angle_deg`.
StatusOr<TriangulatedLight> TriangulateLight(const std::vector<SphereRay>& rays,
                                             double min_angle_deg = 0.5);

}  // namespace matfit::capture
