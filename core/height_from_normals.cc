#include "core/height_from_normals.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/parallel.h"

namespace matfit {
namespace {

// One level of the solve: a W × H grid with spacing s fine texels. Link (p, p+1) along x and
// (p, p+W) along rows (down); each has a weight and a target difference z_b − z_a.
struct Level {
  int w = 0, h = 0;
  std::vector<float> slope_x, slope_down;  // per texel: height change per fine texel
  std::vector<uint8_t> trusted;
  int spacing = 1;
};

// The coarser level: 2 × 2 blocks, slopes averaged over their trusted texels.
Level Coarsen(const Level& f) {
  Level c;
  c.w = (f.w + 1) / 2, c.h = (f.h + 1) / 2, c.spacing = f.spacing * 2;
  const size_t n = size_t(c.w) * c.h;
  c.slope_x.assign(n, 0), c.slope_down.assign(n, 0), c.trusted.assign(n, 0);
  for (int y = 0; y < c.h; ++y)
    for (int x = 0; x < c.w; ++x) {
      double sx = 0, sy = 0;
      int k = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int fx = 2 * x + dx, fy = 2 * y + dy;
          if (fx >= f.w || fy >= f.h) continue;
          const size_t p = size_t(fy) * f.w + fx;
          if (!f.trusted[p]) continue;
          sx += f.slope_x[p], sy += f.slope_down[p], ++k;
        }
      const size_t q = size_t(y) * c.w + x;
      if (k > 0) c.slope_x[q] = float(sx / k), c.slope_down[q] = float(sy / k), c.trusted[q] = 1;
    }
  return c;
}

// Links of a level: weight and target difference (in fine-texel height units).
struct Links {
  std::vector<float> wx, gx, wy, gy;  // link to the right / to the row below, per texel
};

Links MakeLinks(const Level& L, double fill) {
  Links k;
  const size_t n = size_t(L.w) * L.h;
  k.wx.assign(n, 0), k.gx.assign(n, 0), k.wy.assign(n, 0), k.gy.assign(n, 0);
  for (int y = 0; y < L.h; ++y)
    for (int x = 0; x < L.w; ++x) {
      const size_t p = size_t(y) * L.w + x;
      if (x + 1 < L.w) {
        const bool both = L.trusted[p] && L.trusted[p + 1];
        k.wx[p] = both ? 1.f : float(fill);
        k.gx[p] = both ? float(0.5 * (L.slope_x[p] + L.slope_x[p + 1]) * L.spacing) : 0.f;
      }
      if (y + 1 < L.h) {
        const size_t b = p + L.w;
        const bool both = L.trusted[p] && L.trusted[b];
        k.wy[p] = both ? 1.f : float(fill);
        k.gy[p] = both ? float(0.5 * (L.slope_down[p] + L.slope_down[b]) * L.spacing) : 0.f;
      }
    }
  return k;
}

// out = A z, A the weighted graph Laplacian (+ a tiny ridge: the solution is defined up to a
// constant, fixed at mean 0 afterwards).
void Apply(const Level& L, const Links& k, const std::vector<double>& z, std::vector<double>* out) {
  constexpr double kRidge = 1e-9;
  ParallelFor(0, L.h, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < L.w; ++x) {
        const size_t p = size_t(y) * L.w + x;
        double v = kRidge * z[p];
        if (x + 1 < L.w) v += k.wx[p] * (z[p] - z[p + 1]);
        if (x > 0) v += k.wx[p - 1] * (z[p] - z[p - 1]);
        if (y + 1 < L.h) v += k.wy[p] * (z[p] - z[p + L.w]);
        if (y > 0) v += k.wy[p - L.w] * (z[p] - z[p - L.w]);
        (*out)[p] = v;
      }
  });
}

// Σ a_i b_i in fixed chunks (the sum does not depend on the thread count).
double Dot(const std::vector<double>& a, const std::vector<double>& b) {
  constexpr int64_t kChunk = 1 << 14;
  const int64_t chunks = (int64_t(a.size()) + kChunk - 1) / kChunk;
  std::vector<double> part(size_t(chunks), 0);
  ParallelFor(0, chunks, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      double s = 0;
      const size_t e = std::min(a.size(), size_t((c + 1) * kChunk));
      for (size_t i = size_t(c * kChunk); i < e; ++i) s += a[i] * b[i];
      part[size_t(c)] = s;
    }
  });
  double s = 0;
  for (double v : part) s += v;
  return s;
}

// f(i) for every i in [0, n), in parallel.
template <typename F>
void ForEach(size_t n, const F& f) {
  ParallelFor(0, int64_t(n), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) f(size_t(i));
  });
}

// Jacobi-preconditioned conjugate gradients from *z; returns iterations, *residual relative.
int Solve(const Level& L, const Links& k, const HeightOptions& o, std::vector<double>* z,
          double* residual) {
  const size_t n = size_t(L.w) * L.h;
  std::vector<double> b(n, 0), diag(n, 1e-9);
  for (int y = 0; y < L.h; ++y)
    for (int x = 0; x < L.w; ++x) {
      const size_t p = size_t(y) * L.w + x;
      // E = Σ w (z_b − z_a − g)²: ∂/∂z_a gives −w g on a, +w g on b.
      if (x + 1 < L.w) {
        b[p] -= k.wx[p] * k.gx[p], b[p + 1] += k.wx[p] * k.gx[p];
        diag[p] += k.wx[p], diag[p + 1] += k.wx[p];
      }
      if (y + 1 < L.h) {
        b[p] -= k.wy[p] * k.gy[p], b[p + L.w] += k.wy[p] * k.gy[p];
        diag[p] += k.wy[p], diag[p + L.w] += k.wy[p];
      }
    }
  const double bnorm = std::sqrt(Dot(b, b));
  std::vector<double> r(n), d(n), q(n), s(n);
  Apply(L, k, *z, &q);
  for (size_t i = 0; i < n; ++i) r[i] = b[i] - q[i], d[i] = r[i] / diag[i];
  double delta = Dot(r, d);
  int it = 0;
  *residual = bnorm > 0 ? std::sqrt(Dot(r, r)) / bnorm : 0;
  for (; it<o.max_iterations&& * residual> o.tolerance; ++it) {
    Apply(L, k, d, &q);
    const double dq = Dot(d, q);
    if (!(dq > 0)) break;
    const double alpha = delta / dq;
    ForEach(n, [&](size_t i) {
      (*z)[i] += alpha * d[i], r[i] -= alpha * q[i];
      s[i] = r[i] / diag[i];
    });
    const double next = Dot(r, s), beta = next / delta;
    ForEach(n, [&](size_t i) { d[i] = s[i] + beta * d[i]; });
    delta = next;
    *residual = std::sqrt(Dot(r, r)) / bnorm;
  }
  return it;
}

}  // namespace

bool HeightOptions::Check(std::string* why) const {
  if (max_iterations < 1 || !(tolerance > 0) || !(fill_weight > 0 && fill_weight <= 1) ||
      !(max_slope > 0)) {
    *why = "height options: iterations ≥ 1, tolerance > 0, fill weight in (0, 1], slope cap > 0";
    return false;
  }
  return true;
}

HeightResult IntegrateNormals(const Image& normal, const std::vector<uint8_t>& trusted,
                              const HeightOptions& o) {
  HeightResult res;
  const int W = normal.width(), H = normal.height();
  if (W == 0 || H == 0 || normal.channels() < 3) return res;
  // Finest level: slopes from the normals (y up in the map, rows down in memory).
  std::vector<Level> levels(1);
  Level& f = levels[0];
  f.w = W, f.h = H;
  const size_t n = size_t(W) * H;
  f.slope_x.assign(n, 0), f.slope_down.assign(n, 0), f.trusted.assign(n, 0);
  for (size_t p = 0; p < n; ++p) {
    const double nx = normal.Plane(0)[p], ny = normal.Plane(1)[p], nz = normal.Plane(2)[p];
    const bool ok = (trusted.empty() || trusted[p]) && std::isfinite(nx) && std::isfinite(ny) &&
                    std::isfinite(nz) && nz > 0;
    if (!ok) continue;
    f.trusted[p] = 1;
    // dz/dx = −n_x / n_z; dz/dy_up = −n_y / n_z, so dz/drow = +n_y / n_z.
    f.slope_x[p] = float(std::clamp(-nx / nz, -o.max_slope, o.max_slope));
    f.slope_down[p] = float(std::clamp(ny / nz, -o.max_slope, o.max_slope));
  }
  while (levels.back().w > 32 || levels.back().h > 32) {
    Level coarser = Coarsen(levels.back());
    levels.push_back(std::move(coarser));  // (`f` is not used past here: the vector moves)
  }
  // Coarse to fine: each level starts from the coarser answer (nearest upsampling).
  std::vector<double> z;
  for (int li = int(levels.size()) - 1; li >= 0; --li) {
    const Level& L = levels[size_t(li)];
    std::vector<double> start(size_t(L.w) * L.h, 0);
    if (!z.empty()) {  // bilinear: fine texel x sits at coarse (x − 0.5) / 2
      const Level& C = levels[size_t(li) + 1];
      auto at = [&](int cx, int cy) {
        return z[size_t(std::clamp(cy, 0, C.h - 1)) * C.w + std::clamp(cx, 0, C.w - 1)];
      };
      for (int y = 0; y < L.h; ++y)
        for (int x = 0; x < L.w; ++x) {
          const double fx = (x - 0.5) / 2, fy = (y - 0.5) / 2;
          const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
          const double tx = fx - x0, ty = fy - y0;
          start[size_t(y) * L.w + x] = (1 - ty) * ((1 - tx) * at(x0, y0) + tx * at(x0 + 1, y0)) +
                                       ty * ((1 - tx) * at(x0, y0 + 1) + tx * at(x0 + 1, y0 + 1));
        }
    }
    z = std::move(start);
    const Links links = MakeLinks(L, o.fill_weight);
    // The coarsest level is solved to convergence (it is small); the finer ones only correct
    // what the upsampled answer misses, which takes far fewer iterations.
    HeightOptions lo = o;
    if (li == int(levels.size()) - 1)
      lo.max_iterations = std::max(o.max_iterations, 4 * (L.w + L.h));
    double residual = 0;
    const int it = Solve(L, links, lo, &z, &residual);
    if (li == 0) res.iterations = it, res.residual = residual;
  }
  // Mean 0 over trusted texels; range over them.
  double sum = 0;
  int64_t k = 0;
  const std::vector<uint8_t>& fine_trusted = levels[0].trusted;
  for (size_t p = 0; p < n; ++p)
    if (fine_trusted[p]) sum += z[p], ++k;
  const double mean = k > 0 ? sum / double(k) : 0;
  res.height = Image(W, H, 1);
  res.min = k > 0 ? 1e300 : 0, res.max = k > 0 ? -1e300 : 0;
  for (size_t p = 0; p < n; ++p) {
    const double v = z[p] - mean;
    res.height.Plane(0)[p] = float(v);
    if (fine_trusted[p]) res.min = std::min(res.min, v), res.max = std::max(res.max, v);
  }
  return res;
}

}  // namespace matfit
