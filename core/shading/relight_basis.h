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

}  // namespace matfit::shading
