#include "leaf/multipole.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/check.h"

namespace matfit::leaf {

bool MultipoleParams::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(g > -1 && g < 1)) return fail("g must be in (-1, 1), got " + std::to_string(g));
  if (!(sigma_s > 0)) return fail("sigma_s must be > 0 /mm, got " + std::to_string(sigma_s));
  if (!(sigma_a > 0)) return fail("sigma_a must be > 0 /mm, got " + std::to_string(sigma_a));
  if (!(rho_d >= 0 && rho_d < 1))
    return fail("rho_d must be in [0, 1), got " + std::to_string(rho_d));
  if (dipoles < 0 || dipoles > 20) return fail("dipoles must be in 0..20");
  return true;
}

Multipole::Multipole(const MultipoleParams& p) : n_(p.dipoles) {
  MATFIT_CHECK(p.Check(nullptr));
  const double sps = (1 - p.g) * p.sigma_s;  // σ'_s
  const double spt = p.sigma_a + sps;        // σ'_t
  const double D = 1 / (3 * spt);
  l_ = 1 / spt;
  alpha_p_ = sps / spt;
  sigma_tr_ = std::sqrt(3 * p.sigma_a * spt);
  const double A = (1 + p.rho_d) / (1 - p.rho_d);
  zb_ = 2 * A * D;
  min_thickness_ = 1.5 * l_;
}

double Multipole::Transmittance(double r, double d) const {
  const double r2 = r * r;
  double sum = 0;
  for (int j = -n_; j <= n_; ++j) {
    const double zr = 2 * j * (d + 2 * zb_) + l_;
    const double zv = 2 * j * (d + 2 * zb_) - l_ - 2 * zb_;
    const double ar = d - zr, av = d - zv;
    const double dr = std::sqrt(r2 + ar * ar), dv = std::sqrt(r2 + av * av);
    sum += ar * (1 + sigma_tr_ * dr) * std::exp(-sigma_tr_ * dr) / (dr * dr * dr) -
           av * (1 + sigma_tr_ * dv) * std::exp(-sigma_tr_ * dv) / (dv * dv * dv);
  }
  return alpha_p_ / (4 * std::numbers::pi) * sum;
}

double Multipole::Clamped(double r, double d) const { return std::max(0.0, Transmittance(r, d)); }

double Multipole::Radius(double d, double threshold) const {
  // T decays monotonically past the near field; step out coarsely, then bisect.
  double hi = std::max(d, l_);
  while (Clamped(hi, d) >= threshold && hi < 1e3) hi *= 1.5;
  double lo = 0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (Clamped(mid, d) >= threshold ? lo : hi) = mid;
  }
  return hi;
}

}  // namespace matfit::leaf
