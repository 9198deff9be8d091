// Light directions from images of a mirror (chrome) sphere (compute only).
//   Sphere: centre and radius from the mask — an algebraic (Kåsa) circle fit to its boundary
//   pixels, started from the centroid and √(area/π).
//   Highlight: the 8-connected region, grown from the brightest pixel inside the sphere (on the
//   max over channels), of pixels within `highlight_fraction` of it, each weighted by how far
//   above that threshold it is (other bright reflections in the sphere are left out).
//   Normal at a pixel (orthographic): n = ((x − cx)/r, −(y − cy)/r, √(1 − …)), y up.
//   Light: the weighted mean of the highlight pixels' mirror directions of the view,
//   R = 2(n·v)n − v, normalised, with v = (0, 0, 1), or, with a perspective camera of focal
//   length f (pixels, principal point at the image centre), v the unit vector from the pixel
//   toward the camera centre. (Orthographic, every pixel spans the same solid angle of R, so a
//   highlight symmetric about the light averages to it; the image-space centroid of a highlight
//   is biased toward the sphere's centre by foreshortening: 1.2° on 60° lights in the tests.)
#pragma once

#include <vector>

#include "core/image.h"
#include "core/status.h"
#include "core/vec3.h"

namespace matfit::capture {

struct SphereCalibrationOptions {
  double highlight_fraction = 0.5;  // pixels ≥ (1 − fraction) × max form the highlight
  bool perspective = false;
  double focal_px = 0;  // perspective only
};

struct SphereFit {
  double cx = 0, cy = 0, radius = 0;  // pixels (x right, y down)
  double rms_px = 0;                  // of the boundary fit
  double edge_coverage = 0;           // RefineSphere: share of 360 rays with an edge on the circle
};

struct LightEstimate {
  Vec3 direction;         // unit, x right, y up, z toward the camera
  double hx = 0, hy = 0;  // highlight centroid (weighted), pixels: for display
  double peak = 0;        // brightest value
  int pixels = 0;         // in the highlight
};

StatusOr<SphereFit> FitSphere(const Image& mask);
// The algebraic (Kåsa) least-squares circle through the points; false when it degenerates.
bool FitCircle(const std::vector<double>& xs, const std::vector<double>& ys, double* cx, double* cy,
               double* r);
StatusOr<LightEstimate> EstimateLight(const Image& img, const SphereFit& s,
                                      const SphereCalibrationOptions& o);

// Angle between unit vectors, degrees.
double AngleDeg(const Vec3& a, const Vec3& b);

}  // namespace matfit::capture
