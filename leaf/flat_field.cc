#include "leaf/flat_field.h"

#include <Eigen/Dense>
#include <cmath>

namespace matfit::leaf {

bool BackgroundOptions::Check(std::string* why) const {
  if (degree < 0 || degree > 6) {
    if (why) *why = "background degree must be in 0..6, got " + std::to_string(degree);
    return false;
  }
  if (stride < 1 || stride > 64) {
    if (why) *why = "background stride must be in 1..64, got " + std::to_string(stride);
    return false;
  }
  return true;
}

namespace {

// Monomials u^a v^b, a + b ≤ degree.
void Monomials(double u, double v, int degree, double* out) {
  double pu[8], pv[8];
  pu[0] = pv[0] = 1;
  for (int a = 1; a <= degree; ++a) pu[a] = pu[a - 1] * u, pv[a] = pv[a - 1] * v;
  int k = 0;
  for (int a = 0; a <= degree; ++a)
    for (int b = 0; a + b <= degree; ++b) out[k++] = pu[a] * pv[b];
}

}  // namespace

StatusOr<BackgroundFit> FitBackground(std::span<const float> plane, int w, int h,
                                      const std::vector<uint8_t>& background,
                                      const BackgroundOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  if (plane.size() != size_t(w) * h || background.size() != plane.size())
    return InvalidArgument("FitBackground: plane and mask sizes differ");
  const int nt = (o.degree + 1) * (o.degree + 2) / 2;
  auto uv = [&](int x, int y, double* u, double* v) {
    *u = w > 1 ? 2.0 * x / (w - 1) - 1 : 0, *v = h > 1 ? 2.0 * y / (h - 1) - 1 : 0;
  };
  struct Sample {
    int x, y;
    double logi;
  };
  std::vector<Sample> s;
  for (int y = 0; y < h; y += o.stride)
    for (int x = 0; x < w; x += o.stride) {
      const size_t i = size_t(y) * w + x;
      if (background[i] && plane[i] > 1e-6f && std::isfinite(plane[i]))
        s.push_back({x, y, std::log(double(plane[i]))});
    }
  std::vector<uint8_t> keep(s.size(), 1);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(nt);
  BackgroundFit fit;
  std::vector<double> m(nt);
  for (int round = 0; round < 3; ++round) {
    Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(nt, nt);
    Eigen::VectorXd atb = Eigen::VectorXd::Zero(nt);
    int64_t n = 0;
    for (size_t k = 0; k < s.size(); ++k) {
      if (!keep[k]) continue;
      double u, v;
      uv(s[k].x, s[k].y, &u, &v);
      Monomials(u, v, o.degree, m.data());
      const Eigen::Map<const Eigen::VectorXd> a(m.data(), nt);
      ata.selfadjointView<Eigen::Lower>().rankUpdate(a);
      atb += a * s[k].logi;
      ++n;
    }
    if (n < 50 || n < 4 * nt)
      return DataError("too little bare background to model the lighting (" + std::to_string(n) +
                       " samples): the leaves cover the sheet, or the mask is wrong");
    ata = ata.selfadjointView<Eigen::Lower>();
    c = ata.ldlt().solve(atb);
    // Residuals; trim beyond 2.5σ for the next round.
    double ss = 0;
    std::vector<double> r(s.size());
    for (size_t k = 0; k < s.size(); ++k) {
      double u, v;
      uv(s[k].x, s[k].y, &u, &v);
      Monomials(u, v, o.degree, m.data());
      double p = 0;
      for (int t = 0; t < nt; ++t) p += c[t] * m[t];
      r[k] = s[k].logi - p;
      if (keep[k]) ss += r[k] * r[k];
    }
    const double sigma = std::sqrt(ss / n);
    fit.rms_log = sigma, fit.samples = n;
    if (round < 2)
      for (size_t k = 0; k < s.size(); ++k) keep[k] = std::abs(r[k]) <= 2.5 * sigma + 1e-9;
  }
  fit.level = Image(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double u, v;
      uv(x, y, &u, &v);
      Monomials(u, v, o.degree, m.data());
      double p = 0;
      for (int t = 0; t < nt; ++t) p += c[t] * m[t];
      fit.level.At(0, y, x) = float(std::exp(p));
    }
  return fit;
}

}  // namespace matfit::leaf
