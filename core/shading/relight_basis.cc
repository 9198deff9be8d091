#include "core/shading/relight_basis.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace matfit::shading {
namespace {

// Associated Legendre polynomial P_l^m(x), m ≥ 0, with the Condon–Shortley phase.
double Legendre(int l, int m, double x) {
  double pmm = 1;
  if (m > 0) {
    const double somx2 = std::sqrt(std::max(0.0, (1 - x) * (1 + x)));
    double fact = 1;
    for (int i = 1; i <= m; ++i) pmm *= -fact * somx2, fact += 2;
  }
  if (l == m) return pmm;
  double pmmp1 = x * (2 * m + 1) * pmm;
  if (l == m + 1) return pmmp1;
  double pll = 0;
  for (int ll = m + 2; ll <= l; ++ll) {
    pll = ((2 * ll - 1) * x * pmmp1 - (ll + m - 1) * pmm) / (ll - m);
    pmm = pmmp1;
    pmmp1 = pll;
  }
  return pll;
}

double Factorial(int n) {
  double f = 1;
  for (int i = 2; i <= n; ++i) f *= i;
  return f;
}

}  // namespace

void PtmBasis(const Vec3& l, double out[kPtmTerms]) {
  out[0] = l.x * l.x, out[1] = l.y * l.y, out[2] = l.x * l.y;
  out[3] = l.x, out[4] = l.y, out[5] = 1;
}

void HshBasis(int order, const Vec3& dir, double out[kMaxHshTerms]) {
  const double x = 2 * std::clamp(dir.z, 0.0, 1.0) - 1;
  const double phi = std::atan2(dir.y, dir.x);
  for (int l = 0; l < order; ++l)
    for (int m = -l; m <= l; ++m) {
      const int am = std::abs(m);
      const double k =
          std::sqrt((2 * l + 1) * Factorial(l - am) / (2 * std::numbers::pi * Factorial(l + am)));
      const double p = Legendre(l, am, x);
      double v = k * p;
      if (m > 0) v *= std::sqrt(2.0) * std::cos(m * phi);
      if (m < 0) v *= std::sqrt(2.0) * std::sin(am * phi);
      out[l * l + l + m] = v;
    }
}

void RbfTableCoords(const Vec3& l, int G, double* fx, double* fy) {
  const double theta = std::acos(std::clamp(l.z, -1.0, 1.0));
  const double s = std::hypot(l.x, l.y);
  // ρ = θ / 90°, clamped to the horizon; (x, y) = ρ (l_x, l_y) / |(l_x, l_y)|.
  const double rho = std::min(1.0, theta / (std::numbers::pi / 2));
  // Straight up: the centre; straight down: the horizon at φ = 0 (as every other direction below
  // the horizon, a point of the rim).
  const double x = s > 0 ? rho * l.x / s : (l.z < 0 ? 1.0 : 0.0), y = s > 0 ? rho * l.y / s : 0.0;
  *fx = (x + 1) * 0.5 * (G - 1), *fy = (y + 1) * 0.5 * (G - 1);
}

void RbfTableBasis(const float* table, int G, int k, const Vec3& l, double* out) {
  double fx, fy;
  RbfTableCoords(l, G, &fx, &fy);
  const int x0 = std::clamp(int(std::floor(fx)), 0, G - 2);
  const int y0 = std::clamp(int(std::floor(fy)), 0, G - 2);
  const double tx = fx - x0, ty = fy - y0;
  const int64_t plane = int64_t(G) * G;
  for (int q = 0; q < k; ++q) {
    const float* t = table + q * plane + int64_t(y0) * G + x0;
    out[q] = (1 - ty) * ((1 - tx) * t[0] + tx * t[1]) + ty * ((1 - tx) * t[G] + tx * t[G + 1]);
  }
}

}  // namespace matfit::shading
