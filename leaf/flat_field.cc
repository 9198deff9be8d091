#include "leaf/flat_field.h"

#include <Eigen/Dense>
#include <cmath>

namespace matfit::leaf {

bool BackgroundOptions::Check(std::string* why) const {
  if (degree < 0 || degree > 6) {
    if (why) *why = "background degree must be in 0..6, got " + std::to_string(degree);
    return false;
  }
  if (!(saturation > 0 && saturation <= 1)) {
    if (why) *why = "background saturation level must be in (0, 1]";
    return false;
  }
  if (stride < 0 || stride > 64) {
    if (why) *why = "background stride must be in 0 (auto)..64, got " + std::to_string(stride);
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
  // Clipped samples (at or above the saturation level) only bound the background from below:
  // they enter a round, at the clipping level, only where the current fit falls below it
  // (a censored fit). Unclipped samples are trimmed at 2.5σ between rounds.
  struct Sample {
    int x, y;
    double logi;
    bool clipped;
  };
  std::vector<Sample> s;
  // Stride 0: about 40 000 samples whatever the image size (the model has ≤ 28 terms).
  const int stride = o.stride > 0 ? o.stride : std::max(1, int(std::sqrt(double(w) * h / 40000.0)));
  for (int y = 0; y < h; y += stride)
    for (int x = 0; x < w; x += stride) {
      const size_t i = size_t(y) * w + x;
      if (!background[i] || !(plane[i] > 1e-6f) || !std::isfinite(plane[i])) continue;
      const bool clipped = plane[i] >= o.saturation;
      s.push_back({x, y, std::log(clipped ? o.saturation : double(plane[i])), clipped});
    }
  int64_t unclipped = 0;
  for (const auto& e : s) unclipped += !e.clipped;
  std::vector<uint8_t> keep(s.size());
  for (size_t k = 0; k < s.size(); ++k) keep[k] = !s[k].clipped;
  Eigen::VectorXd c = Eigen::VectorXd::Zero(nt);
  BackgroundFit fit;
  std::vector<double> m(nt);
  auto predict = [&](const Sample& e) {
    double u, v;
    uv(e.x, e.y, &u, &v);
    Monomials(u, v, o.degree, m.data());
    double p = 0;
    for (int t = 0; t < nt; ++t) p += c[t] * m[t];
    return p;
  };
  if (unclipped < 50 || unclipped < 4 * nt)
    return DataError("too little unclipped bare background to model the lighting (" +
                     std::to_string(unclipped) +
                     " samples): the leaves cover the sheet, the mask "
                     "is wrong or the exposure clips the sheet everywhere");
  for (int round = 0; round < 5; ++round) {
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
    ata = ata.selfadjointView<Eigen::Lower>();
    c = ata.ldlt().solve(atb);
    double ss = 0;
    int64_t nu = 0;
    std::vector<double> r(s.size());
    for (size_t k = 0; k < s.size(); ++k) {
      r[k] = s[k].logi - predict(s[k]);
      if (keep[k] && !s[k].clipped) ss += r[k] * r[k], ++nu;
    }
    const double sigma = std::sqrt(ss / std::max<int64_t>(1, nu));
    fit.rms_log = sigma, fit.samples = n;
    for (size_t k = 0; k < s.size(); ++k)
      keep[k] = s[k].clipped ? r[k] > 0 : std::abs(r[k]) <= 2.5 * sigma + 1e-9;
  }
  // Evaluate row by row: p(u, v) = Σ_a u^a q_a(v) with q_a(v) = Σ_b c_ab v^b.
  fit.level = Image(w, h, 1);
  std::vector<double> q(o.degree + 1);
  for (int y = 0; y < h; ++y) {
    double u, v;
    uv(0, y, &u, &v);
    int k = 0;
    for (int a = 0; a <= o.degree; ++a) {
      double acc = 0, vb = 1;
      for (int b = 0; a + b <= o.degree; ++b, ++k) acc += c[k] * vb, vb *= v;
      q[a] = acc;
    }
    for (int x = 0; x < w; ++x) {
      uv(x, y, &u, &v);
      double p = 0, ua = 1;
      for (int a = 0; a <= o.degree; ++a) p += q[a] * ua, ua *= u;
      fit.level.At(0, y, x) = float(std::exp(p));
    }
  }
  return fit;
}

}  // namespace matfit::leaf
