// Horizon map for self-shadowing of a height field (METHODS.md §5: 16 azimuth slices).
// Heights in mm on the texel grid; plane k holds the horizon elevation angle (rad) seen from a
// texel along azimuth φ_k = 2πk/S of the frame: atan max_s (Δheight / horizontal distance).
#pragma once

#include <algorithm>
#include <span>

#include "core/image.h"
#include "core/vec3.h"

namespace matfit::leaf {

struct HorizonOptions {
  int slices = 16;
  int max_steps = 48;  // march up to this many texels (geometric steps 1, 2, 3, 4, 6, 8, ...)
};

// A step of +1 along the frame's y axis moves `row_of_y` rows (−1: y = image up, the upper
// side's frame; +1: the lower side's frame, y' = −y). x is always +1 column.
Image HorizonMap(const Image& height_mm, double mm_per_texel, int row_of_y,
                 const HorizonOptions& options);

// Soft step over ±1° of elevation: 1 well above the horizon angle, 0 well below (radians).
inline constexpr float kSoftInvWidth = float(90 / 3.14159265358979323846);  // 1 / (2°), 1/rad
inline float SoftVisibility(float elevation, float horizon_elevation) {
  const float v = (elevation - horizon_elevation) * kSoftInvWidth + 0.5f;
  return std::min(1.0f, std::max(0.0f, v));  // branch-free: vectorises
}

// Visibility V ∈ [0, 1] of direction w (unit, frame coordinates, w.z > 0) at texel p:
// interpolates the horizon between the two nearest slices, soft over ±1° of elevation.
// An empty horizon map means no self-shadowing (V = 1).
float Visibility(const Image& horizon, int64_t p, const Vec3& w);

}  // namespace matfit::leaf
