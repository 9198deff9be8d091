// The N × 3 light matrix L (rows = unit light directions) and what linear fits need of it.
#pragma once

#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/status.h"

namespace matfit::fit {

struct LightMatrix {
  int n = 0;
  std::vector<double> pinv;  // (LᵀL)⁻¹Lᵀ, 3 × n row-major
  double condition = 0;      // σ1/σ3 of L
};

// Fails (naming the problem and the fix) with fewer than 3 lights or coplanar lights.
StatusOr<LightMatrix> MakeLightMatrix(const std::vector<LightSample>& lights);

// Index of the light closest to `view`, if within max_deg degrees, else −1 (seed sample #1).
int FindLightAlong(const std::vector<LightSample>& lights, const Vec3& view, double max_deg);

}  // namespace matfit::fit
