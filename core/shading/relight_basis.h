// Relighting bases (METHODS.md §4): linear in their coefficients, so fitted like Lambert with
// one pseudo-inverse. Evaluated in double; directions are unit, tangent frame.
#pragma once

#include "core/vec3.h"

namespace matfit::shading {

// PTM: (u, v) = (l_x, l_y); terms u², v², uv, u, v, 1.
inline constexpr int kPtmTerms = 6;
void PtmBasis(const Vec3& l, double out[kPtmTerms]);

// Hemispherical harmonics (Gautron et al. 2004): H_l^m(θ, φ) = √2 K_l^m cos(mφ) P_l^m(2cosθ − 1)
// for m > 0, √2 K_l^m sin(|m|φ) P_l^|m|(2cosθ − 1) for m < 0, K_l^0 P_l^0(2cosθ − 1) for m = 0,
// K_l^m = √((2l + 1)(l − |m|)! / (2π (l + |m|)!)); orthonormal over the upper hemisphere.
// `order` bands l = 0 … order − 1 give order² terms, index l² + l + m. order in [1, 4].
inline constexpr int kMaxHshTerms = 16;
void HshBasis(int order, const Vec3& l, double out[kMaxHshTerms]);

// Tabulated basis (the rbf model, fit/rbf_fit.cc): k basis functions of the light direction,
// stored as k planes of a G × G table over the azimuthal-equidistant disc
// (x, y) = (θ / 90°) (cos φ, sin φ) ∈ [−1, 1]² (θ from +z; the horizon is the unit circle,
// directions below it clamp to it); node (i, j) of plane q, value table[q·G² + j·G + i], sits at
// x = −1 + 2i/(G − 1), y = −1 + 2j/(G − 1); values between nodes are bilinear.
// RbfTableCoords maps l to the table's continuous node coordinates (fx, fy) ∈ [0, G − 1]².
void RbfTableCoords(const Vec3& l, int G, double* fx, double* fy);
void RbfTableBasis(const float* table, int G, int k, const Vec3& l, double* out);

}  // namespace matfit::shading
