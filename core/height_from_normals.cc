#include "core/height_from_normals.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/large_page_allocator.h"
#include "core/parallel.h"

namespace matfit {
namespace {

// The normal equations of E = Σ w (z_b − z_a − g)² over neighbour links: A z = b with A the
// weighted graph Laplacian of the texel grid (+ a tiny ridge: the solution is defined up to a
// constant, fixed at mean 0 afterwards). One level of the multigrid hierarchy holds A: weights
// of the link to the right (wx) and to the row below (wy; 0 past the grid's edge) and its
// diagonal. The V-cycle is only a preconditioner, so its levels run in float (half the memory
// traffic of the sweeps, which are bound by it); the conjugate gradients run in double. Every
// level's planes live in one pool (one large block: on huge pages in matfit, see
// app/global_new.cc — a fresh 4 KiB page costs ~10 µs on the test VM, as much as a sweep).
struct Grid {
  int w = 0, h = 0;
  float *wx = nullptr, *wy = nullptr, *diag = nullptr, *inv_diag = nullptr;
  float *x = nullptr, *b = nullptr;  // the level's V-cycle unknowns and right-hand side
  size_t size() const { return size_t(w) * h; }
};
constexpr int kGridPlanes = 6;
constexpr double kRidge = 1e-9;

// Rows per parallel task: levels below ~16k texels run inline.
int64_t RowGrain(const Grid& g) { return std::max<int64_t>(1, 16384 / std::max(1, g.w)); }

// The sizes of the levels: halved (rounding up) until both sides are ≤ 4.
std::vector<std::pair<int, int>> LevelSizes(int w, int h) {
  std::vector<std::pair<int, int>> sizes{{w, h}};
  while (w > 4 || h > 4) w = (w + 1) / 2, h = (h + 1) / 2, sizes.push_back({w, h});
  return sizes;
}

// Points the level's planes into the pool at *cursor (the pool is zero-filled).
void Place(Grid* g, int w, int h, float** cursor) {
  g->w = w, g->h = h;
  float** planes[kGridPlanes] = {&g->wx, &g->wy, &g->diag, &g->inv_diag, &g->x, &g->b};
  for (float** plane : planes) *plane = *cursor, *cursor += g->size();
}

// diag = ridge · (fine texels aggregated) + Σ the texel's links; its inverse.
void Diagonal(Grid* g, double ridge) {
  for (int y = 0; y < g->h; ++y)
    for (int x = 0; x < g->w; ++x) {
      const size_t p = size_t(y) * g->w + x;
      double d = ridge + g->wx[p] + g->wy[p];
      if (x > 0) d += g->wx[p - 1];
      if (y > 0) d += g->wy[p - g->w];
      g->diag[p] = float(d), g->inv_diag[p] = float(1 / d);
    }
}

// Galerkin coarsening Pᵀ A P with P the 2 × 2 aggregation (piecewise constant): a coarse link
// sums the fine links between its two aggregates (again a graph Laplacian, with the ridge of
// the aggregated texels).
void Coarsen(const Grid& f, Grid* c, double ridge) {
  for (int y = 0; y < f.h; ++y)
    for (int x = 0; x < f.w; ++x) {
      const size_t p = size_t(y) * f.w + x, q = size_t(y / 2) * c->w + x / 2;
      if (x & 1) c->wx[q] += f.wx[p];
      if (y & 1) c->wy[q] += f.wy[p];
    }
  Diagonal(c, ridge);
}

// Σ over the four links of texel p of w · v_neighbour (links past the edge have weight 0; the
// rows above and below are read only when they exist).
template <typename V>
inline double Neighbours(const Grid& g, const V* v, size_t p, int x, int64_t y) {
  double s = 0;
  if (x + 1 < g.w) s += double(g.wx[p]) * v[p + 1];
  if (x > 0) s += double(g.wx[p - 1]) * v[p - 1];
  if (y + 1 < g.h) s += double(g.wy[p]) * v[p + g.w];
  if (y > 0) s += double(g.wy[p - g.w]) * v[p - g.w];
  return s;
}

// out = A v on the finest level, in double (the operator the conjugate gradients solve):
// ridge · v_p + Σ_links w (v_p − v_q).
void Apply(const Grid& g, const double* v, double* out) {
  ParallelFor(
      0, g.h,
      [&](int64_t y0, int64_t y1) {
        for (int64_t y = y0; y < y1; ++y)
          for (int x = 0; x < g.w; ++x) {
            const size_t p = size_t(y) * g.w + x;
            double s = kRidge * v[p];
            if (x + 1 < g.w) s += double(g.wx[p]) * (v[p] - v[p + 1]);
            if (x > 0) s += double(g.wx[p - 1]) * (v[p] - v[p - 1]);
            if (y + 1 < g.h) s += double(g.wy[p]) * (v[p] - v[p + g.w]);
            if (y > 0) s += double(g.wy[p - g.w]) * (v[p] - v[p - g.w]);
            out[p] = s;
          }
      },
      RowGrain(g));
}

// One Gauss–Seidel half sweep over the texels of one colour ((x + y) mod 2): each is set to
// solve its own row of A x = b given its neighbours, which are all of the other colour (so the
// rows are independent and the result does not depend on the thread count).
void Sweep(const Grid& g, int colour) {
  ParallelFor(
      0, g.h,
      [&](int64_t y0, int64_t y1) {
        const int w = g.w;
        float* xv = g.x;
        const float *bv = g.b, *wx = g.wx, *wy = g.wy, *id = g.inv_diag;
        for (int64_t y = y0; y < y1; ++y) {
          const int first = int((y + colour) & 1);
          if (y == 0 || y + 1 == g.h || w < 2) {
            for (int x = first; x < w; x += 2) {
              const size_t p = size_t(y) * w + x;
              xv[p] = float((bv[p] + Neighbours(g, xv, p, x, y)) * id[p]);
            }
            continue;
          }
          // Inside the row (x in [1, w − 2]) no test is needed; the two end texels take the
          // tested path (a plain read past them would touch the neighbouring rows' ends, which
          // another task may be writing when w is even).
          auto edge = [&](int x) {
            const size_t p = size_t(y) * w + x;
            xv[p] = float((bv[p] + Neighbours(g, xv, p, x, y)) * id[p]);
          };
          if (first == 0) edge(0);
          const size_t row = size_t(y) * w;
          for (int x = first == 0 ? 2 : 1; x < w - 1; x += 2) {
            const size_t p = row + x;
            const float s = bv[p] + wx[p] * xv[p + 1] + wx[p - 1] * xv[p - 1] + wy[p] * xv[p + w] +
                            wy[p - w] * xv[p - w];
            xv[p] = s * id[p];
          }
          if (((w - 1) & 1) == first) edge(w - 1);
        }
      },
      RowGrain(g));
}

// x ≈ A⁻¹ b on level l by one V-cycle from x = 0: red–black Gauss–Seidel before the coarse
// correction and its mirror image (black–red) after, so the cycle is a symmetric positive
// definite preconditioner. The piecewise-constant prolongation undershoots smooth errors by
// about half, so the correction is scaled by kOverCorrect (any scale keeps the cycle SPD; in
// (0, 2) the two-grid cycle also converges). Measured on
// bench/pack_bench's surface: 2 sweeps and 1.9 converge to 10⁻⁶ in 14 iterations (1 sweep:
// 22; 1.6: 23).
constexpr int kSmooth = 2;
constexpr float kOverCorrect = 1.9f;
void VCycle(const std::vector<Grid>& levels, size_t l) {
  const Grid& g = levels[l];
  if (l + 1 == levels.size()) {  // coarsest (a few texels): symmetric sweeps from 0
    std::fill(g.x, g.x + g.size(), 0.f);
    const int sweeps = 2 * (g.w + g.h);
    for (int k = 0; k < sweeps; ++k) Sweep(g, 0), Sweep(g, 1);
    for (int k = 0; k < sweeps; ++k) Sweep(g, 1), Sweep(g, 0);
    return;
  }
  // The first half sweep from x = 0: a red texel's neighbours are black, still 0.
  ParallelFor(
      0, g.h,
      [&](int64_t y0, int64_t y1) {
        for (int64_t y = y0; y < y1; ++y)
          for (int x = int(y & 1); x < g.w; x += 2) {
            const size_t p = size_t(y) * g.w + x;
            g.x[p] = g.b[p] * g.inv_diag[p];
          }
      },
      RowGrain(g));
  Sweep(g, 1);
  for (int k = 1; k < kSmooth; ++k) Sweep(g, 0), Sweep(g, 1);
  // b_c = Pᵀ (b − A x), a coarse row from its two fine rows.
  const Grid& c = levels[l + 1];
  ParallelFor(
      0, c.h,
      [&](int64_t cy0, int64_t cy1) {
        std::vector<float> row(size_t(g.w));  // b − A x of one fine row
        for (int64_t cy = cy0; cy < cy1; ++cy) {
          float* cb = c.b + size_t(cy) * c.w;
          std::fill(cb, cb + c.w, 0.f);
          for (int64_t y = 2 * cy; y < std::min<int64_t>(2 * cy + 2, g.h); ++y) {
            float* r = row.data();
            const size_t o = size_t(y) * g.w;
            if (y == 0 || y + 1 == g.h || g.w < 2) {
              for (int x = 0; x < g.w; ++x)
                r[x] = float(g.b[o + x] - (double(g.diag[o + x]) * g.x[o + x] -
                                           Neighbours(g, g.x, o + x, x, y)));
            } else {  // inside rows the links past the edge have weight 0 (as in Sweep)
              const float *xv = g.x + o, *wx = g.wx + o, *wy = g.wy + o, *b = g.b + o,
                          *d = g.diag + o;
              for (int x = 0; x < g.w; ++x)
                r[x] = b[x] - (d[x] * xv[x] - wx[x] * xv[x + 1] - wx[x - 1] * xv[x - 1] -
                               wy[x] * xv[x + g.w] - wy[x - g.w] * xv[x - g.w]);
            }
            for (int x = 0; x < g.w; ++x) cb[x / 2] += r[x];
          }
        }
      },
      RowGrain(c));
  VCycle(levels, l + 1);
  ParallelFor(
      0, g.h,
      [&](int64_t y0, int64_t y1) {
        for (int64_t y = y0; y < y1; ++y)
          for (int x = 0; x < g.w; ++x)
            g.x[size_t(y) * g.w + x] += kOverCorrect * c.x[size_t(y / 2) * c.w + x / 2];
      },
      RowGrain(g));
  for (int k = 0; k < kSmooth; ++k) Sweep(g, 1), Sweep(g, 0);
}

// Σ a_i b_i in fixed chunks (the sum does not depend on the thread count).
double Dot(const double* a, const double* b, size_t n) {
  constexpr int64_t kChunk = 1 << 14;
  const int64_t chunks = (int64_t(n) + kChunk - 1) / kChunk;
  std::vector<double> part(size_t(chunks), 0);
  ParallelFor(0, chunks, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      double s = 0;
      const size_t e = std::min(n, size_t((c + 1) * kChunk));
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
  ParallelFor(
      0, int64_t(n),
      [&](int64_t b, int64_t e) {
        for (int64_t i = b; i < e; ++i) f(size_t(i));
      },
      16384);
}

// Conjugate gradients on levels[0] (A z = b, from z = 0; b is passed in r), preconditioned by
// one V-cycle per iteration; returns the iterations, *residual the relative residual reached.
// work holds 4 planes of the finest level's size (z, r, d, q).
int Solve(const std::vector<Grid>& levels, const HeightOptions& o, double* work, double* residual) {
  const Grid& g = levels[0];
  const size_t n = g.size();
  double *z = work, *r = work + n, *d = work + 2 * n, *q = work + 3 * n;
  const double bnorm = std::sqrt(Dot(r, r, n));
  *residual = 0;
  if (!(bnorm > 0)) return 0;
  *residual = 1;
  // out = M⁻¹ r through the finest level's float planes.
  auto precondition = [&](double* out) {
    ForEach(n, [&](size_t i) { g.b[i] = float(r[i]); });
    VCycle(levels, 0);
    ForEach(n, [&](size_t i) { out[i] = g.x[i]; });
  };
  precondition(d);
  double delta = Dot(r, d, n);
  int it = 0;
  while (it<o.max_iterations&& * residual> o.tolerance) {
    Apply(g, d, q);
    const double dq = Dot(d, q, n);
    if (!(dq > 0)) break;
    const double alpha = delta / dq;
    ForEach(n, [&](size_t i) { z[i] += alpha * d[i], r[i] -= alpha * q[i]; });
    ++it;
    *residual = std::sqrt(Dot(r, r, n)) / bnorm;
    if (*residual <= o.tolerance) break;
    precondition(q);  // q is free until the next Apply
    const double next = Dot(r, q, n), beta = next / delta;
    ForEach(n, [&](size_t i) { d[i] = q[i] + beta * d[i]; });
    delta = next;
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

namespace {

// v[0, n) = 0, in blocks of 64 KiB over the threads.
template <typename T>
void ZeroInParallel(T* v, size_t n) {
  constexpr int64_t kBlock = 65536 / sizeof(T);
  ParallelFor(0, int64_t((n + kBlock - 1) / kBlock), [&](int64_t b0, int64_t b1) {
    const size_t from = size_t(b0 * kBlock), to = std::min(n, size_t(b1 * kBlock));
    std::fill(v + from, v + to, T(0));
  });
}

}  // namespace

HeightResult IntegrateNormals(const Image& normal, const std::vector<uint8_t>& trusted,
                              const HeightOptions& o) {
  HeightResult res;
  const int W = normal.width(), H = normal.height();
  if (W == 0 || H == 0 || normal.channels() < 3) return res;
  const size_t n = size_t(W) * H;
  const auto sizes = LevelSizes(W, H);
  size_t floats = 0;
  for (auto [w, h] : sizes) floats += size_t(kGridPlanes) * size_t(w) * h;
  // Zero-filled by both threads: a first touch costs more than the write on some VMs, and one
  // thread faulting in 11 MB (512×344) was a serial step of the pack's write.
  std::vector<float, LargePageAllocator<float>> pool;
  std::vector<double, LargePageAllocator<double>> work;  // z, r, d, q of the conjugate gradients
  pool.resize(floats), work.resize(4 * n);
  ZeroInParallel(pool.data(), pool.size());
  ZeroInParallel(work.data(), work.size());
  std::vector<Grid> levels(sizes.size());
  float* cursor = pool.data();
  for (size_t l = 0; l < sizes.size(); ++l)
    Place(&levels[l], sizes[l].first, sizes[l].second, &cursor);

  // Slopes from the normals (y up in the map, rows down in memory): dz/dx = −n_x / n_z,
  // dz/dy_up = −n_y / n_z, so dz/drow = +n_y / n_z; texels without a usable normal have none.
  std::vector<uint8_t> ok(n, 0);
  auto slope = [&](size_t p, int axis) {
    const double nz = normal.Plane(2)[p];
    const double s = axis == 0 ? -normal.Plane(0)[p] / nz : normal.Plane(1)[p] / nz;
    return std::clamp(s, -o.max_slope, o.max_slope);
  };
  for (size_t p = 0; p < n; ++p) {
    const float nx = normal.Plane(0)[p], ny = normal.Plane(1)[p], nz = normal.Plane(2)[p];
    ok[p] = (trusted.empty() || trusted[p]) && std::isfinite(nx) && std::isfinite(ny) &&
            std::isfinite(nz) && nz > 0;
  }
  // Links: weight 1 and the pair's mean slope between trusted texels, else the fill weight and
  // slope 0. ∂E/∂z gives −w g on a link's first texel and +w g on its second (b, held in r).
  Grid& f = levels[0];
  double* b = work.data() + n;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t p = size_t(y) * W + x;
      auto link = [&](size_t q, int axis, float* weight) {
        const bool both = ok[p] && ok[q];
        *weight = both ? 1.f : float(o.fill_weight);
        const double g = both ? 0.5 * (slope(p, axis) + slope(q, axis)) * *weight : 0.0;
        b[p] -= g, b[q] += g;
      };
      if (x + 1 < W) link(p + 1, 0, &f.wx[p]);
      if (y + 1 < H) link(p + size_t(W), 1, &f.wy[p]);
    }
  Diagonal(&f, kRidge);
  double ridge = kRidge;
  for (size_t l = 1; l < levels.size(); ++l) Coarsen(levels[l - 1], &levels[l], ridge *= 4);
  res.iterations = Solve(levels, o, work.data(), &res.residual);
  const double* z = work.data();
  // Mean 0 over trusted texels; range over them.
  double sum = 0;
  int64_t k = 0;
  for (size_t p = 0; p < n; ++p)
    if (ok[p]) sum += z[p], ++k;
  const double mean = k > 0 ? sum / double(k) : 0;
  res.height = Image(W, H, 1);
  res.min = k > 0 ? 1e300 : 0, res.max = k > 0 ? -1e300 : 0;
  for (size_t p = 0; p < n; ++p) {
    const double v = z[p] - mean;
    res.height.Plane(0)[p] = float(v);
    if (ok[p]) res.min = std::min(res.min, v), res.max = std::max(res.max, v);
  }
  return res;
}

}  // namespace matfit
