// Reflective spheres found inside ordinary capture photos (highlight RTI: a chrome or black
// glossy sphere beside the sample in every photo), compute only.
//   Detection: circles (OpenCV's gradient Hough transform, HOUGH_GRADIENT_ALT: Canny 60, circle
//   quality 0.7) on the stack's
//   mean luminance, square-root stretched to its 90th percentile (the highlights saturate) and
//   blurred; each candidate
//   is scored by the photos whose brightest pixel inside it is a compact highlight (a mirror
//   sphere shows the light as one small spot; a matte disc or a hole in the sample does not);
//   those with one in at least half the photos are refined (below), fits whose edge points
//   stray (rms above max(1 px, 1 % of r)) dropped, and the rest ranked by that share (10 %
//   bands), then by the share of the circle that is a clear edge; the best non-overlapping
//   ones are kept.
//   Refinement: along 360 rays from the centre, the strongest radial step of the stretched mean
//   image between 0.75 r and 1.25 r, placed where the blurred linear profile crosses halfway
//   between its levels on either side (an ideal step's position), is an edge point; a Kåsa circle
//   fit to the edge points, refitted twice without points beyond 2.5 MAD, gives centre and
//   radius to a fraction of a pixel.
#pragma once

#include <string>
#include <vector>

#include "capture/calibrate.h"
#include "core/image.h"
#include "core/status.h"

namespace matfit::capture {

// What detection needs of a photo set, gathered one photo at a time (the set need not fit in
// memory): the full-resolution mean luminance (max over channels, linear) and every photo's
// luminance box-downsampled by `factor` (long side ≤ 640 pixels) for scoring.
struct SphereEvidence {
  Image mean;
  std::vector<Image> small;
  int factor = 1;
  int count = 0;
  Status Add(const Image& photo);  // all photos of one size
};

struct SphereDetectOptions {
  int spheres = 1;                // how many to return (the best first)
  double min_radius_frac = 0.02;  // of the image's short side
  double max_radius_frac = 0.49;
  bool Check(std::string* why) const;
};

// The `spheres` best spheres of the photo set, in full-resolution pixels, refined.
StatusOr<std::vector<SphereFit>> DetectSpheres(const SphereEvidence& evidence,
                                               const SphereDetectOptions& options);

// Sub-pixel centre and radius of the sphere near (cx, cy, r) in the mean luminance.
StatusOr<SphereFit> RefineSphere(const Image& mean_luminance, double cx, double cy, double r);

}  // namespace matfit::capture
