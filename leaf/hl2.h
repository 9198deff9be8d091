// Half-Life-2 basis on the hemisphere and its projection (METHODS.md §5).
// ℋ_i(ω) = √(3/(2π)) H_i·ω (unclamped), orthonormal on the upper hemisphere.
#pragma once

#include <array>
#include <vector>

#include "core/vec3.h"

namespace matfit::leaf {

// ℋ_i(ω) for i = 0..2.
double Hl2Basis(int i, const Vec3& w);
std::array<double, 3> Hl2Basis(const Vec3& w);

// N stratified directions, uniform in solid angle over the upper hemisphere: the centres of an
// a×b grid of strata (a·b = N, a = the largest divisor of N not above √N) mapped by Shirley's
// concentric square-to-disk map, lifted area-preservingly: ω = (x√(2−r²), y√(2−r²), 1−r²).
// n must pass StratifiableDirectionCount.
std::vector<Vec3> StratifiedHemisphere(int n);
// True when n = a·b with a ≤ b ≤ 2a (a the largest divisor of n not above √n): thinner grids
// (a prime n gives 1 × n) do not sample the hemisphere evenly.
bool StratifiableDirectionCount(int n);

// Projection weight: h_i = (2π/N) Σ_m ℋ_i(ω_m) f(ω_m).
inline double Hl2ProjectionWeight(int n) { return 2 * 3.14159265358979323846 / n; }

// Σ_i h_i ℋ_i(ω), unclamped.
double Hl2Reconstruct(const std::array<double, 3>& h, const Vec3& w);

// h_i of the pure diffuse translucency n·ω with n = z: √(2π)/3.
inline constexpr double kHl2DiffuseCoefficient = 0.83554275821033340;

}  // namespace matfit::leaf
