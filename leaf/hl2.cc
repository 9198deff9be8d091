#include "leaf/hl2.h"

#include <cmath>
#include <numbers>

#include "core/check.h"
#include "core/shading/shading.h"

namespace matfit::leaf {

double Hl2Basis(int i, const Vec3& w) {
  const auto& H = shading::kHl2[i];
  return shading::kHl2Scale * (H[0] * w.x + H[1] * w.y + H[2] * w.z);
}

std::array<double, 3> Hl2Basis(const Vec3& w) {
  return {Hl2Basis(0, w), Hl2Basis(1, w), Hl2Basis(2, w)};
}

double Hl2Reconstruct(const std::array<double, 3>& h, const Vec3& w) {
  return h[0] * Hl2Basis(0, w) + h[1] * Hl2Basis(1, w) + h[2] * Hl2Basis(2, w);
}

namespace {

// Shirley–Chiu concentric map of [−1, 1]² to the unit disk (area-preserving).
void ConcentricDisk(double a, double b, double* x, double* y) {
  constexpr double kPi4 = std::numbers::pi / 4;
  if (a == 0 && b == 0) {
    *x = *y = 0;
    return;
  }
  double r, phi;
  if (std::abs(a) > std::abs(b)) {
    r = a, phi = kPi4 * (b / a);
  } else {
    r = b, phi = 2 * kPi4 - kPi4 * (a / b);
  }
  *x = r * std::cos(phi), *y = r * std::sin(phi);
}

}  // namespace

namespace {
int GridRows(int n) {
  int a = int(std::sqrt(double(n)));
  while (a > 1 && n % a != 0) --a;
  return a;
}
}  // namespace

bool StratifiableDirectionCount(int n) {
  if (n < 1) return false;
  const int a = GridRows(n);
  return n / a <= 2 * a;
}

std::vector<Vec3> StratifiedHemisphere(int n) {
  MATFIT_CHECK(StratifiableDirectionCount(n));
  const int a = GridRows(n), b = n / a;
  std::vector<Vec3> dirs;
  dirs.reserve(n);
  for (int i = 0; i < a; ++i)
    for (int j = 0; j < b; ++j) {
      double x, y;
      ConcentricDisk(2 * (i + 0.5) / a - 1, 2 * (j + 0.5) / b - 1, &x, &y);
      const double r2 = x * x + y * y, s = std::sqrt(std::max(0.0, 2 - r2));
      dirs.push_back(Normalize(Vec3(x * s, y * s, 1 - r2)));
    }
  return dirs;
}

}  // namespace matfit::leaf
