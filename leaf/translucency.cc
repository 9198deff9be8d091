#include "leaf/translucency.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <optional>

#include "core/parallel.h"
#include "core/warnings.h"
#include "leaf/hl2.h"
#include "leaf/horizon.h"
#include "leaf/projection_kernel.h"

namespace matfit::leaf {

bool TranslucencyOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!multipole.Check(why)) return false;
  if (directions < 3 || directions > 65536)
    return fail("directions (N_L) must be in 3..65536, got " + std::to_string(directions));
  if (!StratifiableDirectionCount(directions))
    return fail("directions (N_L) = " + std::to_string(directions) +
                " does not split into a × b strata with b ≤ 2a (e.g. 32, 64, 128, 144, 256, 512)");
  if (!(kernel_threshold > 0))
    return fail("kernel_threshold must be > 0 /mm², got " + std::to_string(kernel_threshold));
  if (max_kernel_radius < 1 || max_kernel_radius > 1024)
    return fail("max_kernel_radius must be in 1..1024 texels");
  if (!(kernel_tolerance > 0 && kernel_tolerance < 1))
    return fail("kernel_tolerance must be in (0, 1)");
  if (max_kernel_terms < 1 || max_kernel_terms > 48)
    return fail("max_kernel_terms must be in 1..48");
  return true;
}

namespace {

constexpr double kPi = std::numbers::pi;

// Everything both methods derive from the input before transport.
struct Prepared {
  std::optional<Multipole> mp;  // the kernel (set once the options are valid)
  int w = 0, h = 0;
  int64_t n = 0;
  double ap = 0;                // texel area, mm²
  std::vector<uint8_t> inside;  // mask
  std::vector<float> d;         // thickness clamped to the validity limit (mm)
  std::vector<float> rho;       // transmission weight, 0 outside the mask
  double d_lo = 0, d_hi = 0;    // thickness range over the mask
  int radius = 0;
  std::vector<uint8_t> thin;
  int64_t thin_texels = 0;
  bool cut = false;
};

Status Validate(const TransportInput& in, const TranslucencyOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument("translucency options: " + why);
  if (!in.rho || !in.thickness || in.rho->empty() || in.thickness->empty())
    return InvalidArgument("translucency precompute needs a transmission map and a thickness map");
  const int w = in.rho->width(), h = in.rho->height();
  auto same = [&](const Image* im, int ch, const char* what) -> Status {
    if (im && !im->empty() && (im->width() != w || im->height() != h || im->channels() < ch))
      return InvalidArgument(std::string(what) + " map is " + std::to_string(im->width()) + "x" +
                             std::to_string(im->height()) + ", expected " + std::to_string(w) +
                             "x" + std::to_string(h));
    return Status::Ok();
  };
  MATFIT_RETURN_IF_ERROR(same(in.thickness, 1, "thickness"));
  MATFIT_RETURN_IF_ERROR(same(in.normal, 3, "normal"));
  MATFIT_RETURN_IF_ERROR(same(in.horizon, 1, "horizon"));
  if (in.mask && in.mask->size() != size_t(w) * h)
    return InvalidArgument("mask size does not match the transmission map");
  if (!(in.mm_per_texel > 0 && in.mm_per_texel < 100))
    return InvalidArgument("mm_per_texel must be in (0, 100) mm, got " +
                           std::to_string(in.mm_per_texel));
  return Status::Ok();
}

// Validates the input and options, then derives what both methods need.
StatusOr<Prepared> Prepare(const TransportInput& in, const TranslucencyOptions& o) {
  MATFIT_RETURN_IF_ERROR(Validate(in, o));
  Prepared p;
  p.mp.emplace(o.multipole);
  const Multipole& mp = *p.mp;
  p.w = in.rho->width(), p.h = in.rho->height(), p.n = int64_t(p.w) * p.h;
  p.ap = in.mm_per_texel * in.mm_per_texel;
  p.inside.assign(p.n, 1);
  if (in.mask) p.inside = *in.mask;
  p.d.assign(p.n, 0), p.rho.assign(p.n, 0), p.thin.assign(p.n, 0);
  const float dmin = float(mp.min_thickness());
  p.d_lo = 1e30, p.d_hi = 0;
  const auto thick = in.thickness->Plane(0), rho = in.rho->Plane(0);
  for (int64_t i = 0; i < p.n; ++i) {
    if (!p.inside[i]) continue;
    float d = thick[i];
    if (!std::isfinite(d) || d < dmin) {
      d = dmin;
      p.thin[i] = 1;
      ++p.thin_texels;
    }
    p.d[i] = d;
    p.rho[i] = std::isfinite(rho[i]) ? std::max(0.0f, rho[i]) : 0.0f;
    p.d_lo = std::min(p.d_lo, double(d)), p.d_hi = std::max(p.d_hi, double(d));
  }
  if (p.d_hi == 0) p.d_lo = p.d_hi = dmin;  // empty mask
  for (int64_t i = 0; i < p.n; ++i)
    if (!p.inside[i]) p.d[i] = float(p.d_lo);
  // The kernel widens with thickness: size it at the thickest texel.
  const double r_mm = mp.Radius(p.d_hi, o.kernel_threshold);
  const double r_tex = std::ceil(r_mm / in.mm_per_texel);  // clamp before the cast
  p.cut = r_tex > o.max_kernel_radius;
  p.radius = std::max(1, int(std::min(r_tex, double(o.max_kernel_radius))));
  return p;
}

// Disk of texel offsets with |offset| ≤ radius. The kernel is radial, so it is evaluated once
// per distinct distance (ring) and looked up per offset.
struct Offsets {
  std::vector<int> dx, dy, ring;
  std::vector<double> r_mm;       // per offset
  std::vector<double> ring_r_mm;  // per distinct distance
};
Offsets DiskOffsets(int radius, double mm) {
  Offsets o;
  std::vector<int> ring_of_r2(size_t(radius) * radius + 1, -1);
  for (int y = -radius; y <= radius; ++y)
    for (int x = -radius; x <= radius; ++x) {
      const int r2 = x * x + y * y;
      if (r2 > radius * radius) continue;
      if (ring_of_r2[r2] < 0) {
        ring_of_r2[r2] = int(o.ring_r_mm.size());
        o.ring_r_mm.push_back(mm * std::sqrt(double(r2)));
      }
      o.dx.push_back(x), o.dy.push_back(y), o.ring.push_back(ring_of_r2[r2]);
      o.r_mm.push_back(mm * std::sqrt(double(r2)));
    }
  return o;
}

// Per-direction constants for the irradiance E(x, ω).
struct Direction {
  Vec3 w;
  float elevation = 0;  // rad
  int k0 = 0, k1 = 0;   // horizon slices
  float t = 0;          // interpolation weight between them
  double hl2[3] = {0, 0, 0};
};
Direction MakeDirection(const Vec3& w, int slices) {
  Direction d;
  d.w = w;
  const double horiz = std::sqrt(w.x * w.x + w.y * w.y);
  d.elevation = float(std::atan2(w.z, horiz));
  double phi = std::atan2(w.y, w.x);
  if (phi < 0) phi += 2 * kPi;
  const double f = phi / (2 * kPi) * std::max(slices, 1);
  d.k0 = slices > 0 ? int(f) % slices : 0, d.k1 = slices > 0 ? (d.k0 + 1) % slices : 0;
  d.t = float(f - std::floor(f));
  for (int i = 0; i < 3; ++i) d.hl2[i] = Hl2Basis(i, w);
  return d;
}

// E(x, ω) = ρ V max(0, n·ω) over texels [b, e) into out[b..e).
void Irradiance(const TransportInput& in, const Prepared& p, const Direction& dir, int64_t b,
                int64_t e, float* __restrict out) {
  const float wx = float(dir.w.x), wy = float(dir.w.y), wz = float(dir.w.z);
  const float* __restrict rho = p.rho.data();
  if (in.normal) {
    const float* __restrict nx = in.normal->Plane(0).data();
    const float* __restrict ny = in.normal->Plane(1).data();
    const float* __restrict nz = in.normal->Plane(2).data();
    for (int64_t i = b; i < e; ++i)
      out[i] = rho[i] * std::max(0.0f, nx[i] * wx + ny[i] * wy + nz[i] * wz);
  } else {
    for (int64_t i = b; i < e; ++i) out[i] = rho[i] * std::max(0.0f, wz);
  }
  if (!in.horizon || in.horizon->empty() || dir.w.z >= 1 - 1e-9) return;
  const float* __restrict h0 = in.horizon->Plane(dir.k0).data();
  const float* __restrict h1 = in.horizon->Plane(dir.k1).data();
  const float t = dir.t, el = dir.elevation;
  for (int64_t i = b; i < e; ++i) out[i] *= SoftVisibility(el, h0[i] + (h1[i] - h0[i]) * t);
}

std::vector<Direction> Directions(const TransportInput& in, int n) {
  const int slices = in.horizon && !in.horizon->empty() ? in.horizon->channels() : 0;
  std::vector<Direction> dirs;
  for (const Vec3& w : StratifiedHemisphere(n)) dirs.push_back(MakeDirection(w, slices));
  return dirs;
}

void Finish(const Prepared& p, TranslucencyResult* r) {
  r->hl2 = Image(p.w, p.h, 3, float(kHl2DiffuseCoefficient));
  for (int64_t i = 0; i < p.n; ++i) {
    const float R = r->response.Plane(0)[i];
    if (!p.inside[i] || !(R > 1e-12f)) continue;
    for (int c = 0; c < 3; ++c) r->hl2.Plane(c)[i] = r->hl2_raw.Plane(c)[i] / R;
  }
  r->thin = p.thin;
  r->thin_texels = p.thin_texels;
  r->kernel_radius = p.radius;
  r->kernel_cut = p.cut;
  if (p.cut)
    r->warnings.push_back(
        Warning(WarningCode::kKernelRadiusCut,
                "translucency kernel radius cut to " + std::to_string(p.radius) +
                    " texels (raise max_kernel_radius or use a coarser texel pitch)"));
  if (p.thin_texels > 0)
    r->warnings.push_back(
        Warning(WarningCode::kThinTexels,
                std::to_string(p.thin_texels) +
                    " texels thinner than the multipole model's validity (1.5 l) were "
                    "clamped to it and flagged"));
}

// Direct gather: out_m(x_o) = A_p Σ T(|x_o − x_i|, d(x_i)) E_m(x_i) for m < nd, plus the
// response R. E is texel-major (E[i·nd + m]); `sink` receives (texel, sums[nd], R).
// Direct gather: out_m(x_o) = A_p Σ T(|x_o − x_i|, d(x_i)) E_m(x_i) for m < nd, plus the
// response R, at the output texels `outputs` (leaf texels). E is texel-major (E[i·nd + m]);
// `sink` receives (texel, sums[nd], R).
template <typename Sink>
void DirectSum(const Prepared& p, const Multipole& mp, double mm, const std::vector<float>& E,
               int nd, const std::vector<int64_t>& outputs, Sink&& sink) {
  const Offsets off = DiskOffsets(p.radius, mm);
  ParallelFor(
      0, int64_t(outputs.size()),
      [&](int64_t b, int64_t e) {
        std::vector<double> acc(nd);
        for (int64_t j = b; j < e; ++j) {
          const int64_t o = outputs[j];
          const int x = int(o % p.w), y = int(o / p.w);
          std::fill(acc.begin(), acc.end(), 0.0);
          double resp = 0;
          for (size_t k = 0; k < off.dx.size(); ++k) {
            const int xi = x + off.dx[k], yi = y + off.dy[k];
            if (xi < 0 || yi < 0 || xi >= p.w || yi >= p.h) continue;
            const int64_t i = int64_t(yi) * p.w + xi;
            if (!p.inside[i]) continue;
            const double t = p.ap * mp.Clamped(off.r_mm[k], p.d[i]);
            const float* ev = &E[i * nd];
            for (int m = 0; m < nd; ++m) acc[m] += t * ev[m];
            resp += t * p.rho[i];
          }
          sink(o, acc.data(), resp);
        }
      },
      64);
}

std::vector<int64_t> LeafTexels(const Prepared& p) {
  std::vector<int64_t> v;
  for (int64_t i = 0; i < p.n; ++i)
    if (p.inside[i]) v.push_back(i);
  return v;
}

}  // namespace

StatusOr<TranslucencyResult> PrecomputeTranslucencyReference(const TransportInput& in,
                                                             const TranslucencyOptions& o) {
  auto prep = Prepare(in, o);
  if (!prep.ok()) return prep.status();
  const Prepared& p = *prep;
  const Multipole& mp = *p.mp;
  const int nd = o.directions;
  if (p.n * nd > (int64_t(1) << 28))
    return InvalidArgument("the reference precompute holds N_L irradiance planes: " +
                           std::to_string(p.w) + "x" + std::to_string(p.h) + " x " +
                           std::to_string(nd) + " directions is too large (use the fast method)");
  const auto dirs = Directions(in, nd);
  // E for every direction, texel-major.
  std::vector<float> E(size_t(p.n) * nd);
  ParallelFor(
      0, p.n,
      [&](int64_t b, int64_t e) {
        std::vector<float> tmp(e - b);
        for (int m = 0; m < nd; ++m) {
          Irradiance(in, p, dirs[m], b, e, tmp.data() - b);
          for (int64_t i = b; i < e; ++i) E[i * nd + m] = tmp[i - b];
        }
      },
      4096);
  TranslucencyResult r;
  r.hl2_raw = Image(p.w, p.h, 3), r.response = Image(p.w, p.h, 1);
  const double wproj = Hl2ProjectionWeight(nd);
  // N_L non-stationary convolutions (the kernel value of each texel pair is evaluated once and
  // shared by all directions), then the projection.
  DirectSum(p, mp, in.mm_per_texel, E, nd, LeafTexels(p),
            [&](int64_t t, const double* L, double resp) {
              for (int c = 0; c < 3; ++c) {
                double h = 0;
                for (int m = 0; m < nd; ++m) h += dirs[m].hl2[c] * L[m];
                r.hl2_raw.Plane(c)[t] = float(wproj * h);
              }
              r.response.Plane(0)[t] = float(resp);
            });
  Finish(p, &r);
  return r;
}

StatusOr<std::vector<Image>> DirectionalTranslucency(const TransportInput& in,
                                                     const TranslucencyOptions& o,
                                                     const std::vector<Vec3>& lights,
                                                     const std::vector<int64_t>* texels) {
  for (const Vec3& w : lights)
    if (!(w.z > 0)) return InvalidArgument("DirectionalTranslucency needs lights with w.z > 0");
  auto prep = Prepare(in, o);
  if (!prep.ok()) return prep.status();
  const Prepared& p = *prep;
  const Multipole& mp = *p.mp;
  const int slices = in.horizon && !in.horizon->empty() ? in.horizon->channels() : 0;
  const int nd = int(lights.size());
  std::vector<float> E(size_t(p.n) * nd), tmp(p.n);
  for (int m = 0; m < nd; ++m) {
    Irradiance(in, p, MakeDirection(Normalize(lights[m]), slices), 0, p.n, tmp.data());
    for (int64_t i = 0; i < p.n; ++i) E[i * nd + m] = tmp[i];
  }
  std::vector<int64_t> outputs;
  if (texels) {
    for (int64_t i : *texels)
      if (i >= 0 && i < p.n && p.inside[i]) outputs.push_back(i);
  } else {
    outputs = LeafTexels(p);
  }
  std::vector<Image> out(nd, Image(p.w, p.h, 1));
  DirectSum(p, mp, in.mm_per_texel, E, nd, outputs, [&](int64_t t, const double* L, double) {
    for (int m = 0; m < nd; ++m) out[m].Plane(0)[t] = float(L[m]);
  });
  return out;
}

StatusOr<Image> DirectionalTranslucency(const TransportInput& in, const TranslucencyOptions& o,
                                        const Vec3& w) {
  auto v = DirectionalTranslucency(in, o, std::vector<Vec3>{w}, nullptr);
  if (!v.ok()) return v.status();
  return std::move((*v)[0]);
}

namespace {

// The discrete kernel A_p max(0, T(r, d)) on the offset disk.
std::vector<double> KernelValues(const Multipole& mp, const Offsets& off, double ap, double d) {
  std::vector<double> ring(off.ring_r_mm.size());
  for (size_t i = 0; i < ring.size(); ++i) ring[i] = ap * mp.Clamped(off.ring_r_mm[i], d);
  std::vector<double> k(off.ring.size());
  for (size_t i = 0; i < k.size(); ++i) k[i] = ring[off.ring[i]];
  return k;
}
double Sum(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s;
}

// Low-rank thickness expansion of the kernel family: K(r; d) ≈ Σ_q A_q(d) B_q(r), B_q the
// leading singular vectors of the unit-energy kernels K(d_j)/g(d_j) at J geometric thickness
// samples, A_q(d_j) = ⟨K(d_j), B_q⟩ interpolated linearly in log d between samples.
struct KernelBasis {
  std::vector<std::vector<double>> B;  // Q × offsets
  std::vector<std::vector<double>> A;  // Q × J
  double lo = 0, log_ratio = 0;        // d_j = lo · exp(log_ratio · j / (J − 1))
  int J = 1;
  double error = 0;  // worst relative L1 error over the samples and their midpoints
  // Coefficients at thickness d.
  void At(double d, double* a) const {
    if (J == 1) {
      for (size_t q = 0; q < A.size(); ++q) a[q] = A[q][0];
      return;
    }
    const double f = std::clamp(std::log(d / lo) / log_ratio, 0.0, 1.0) * (J - 1);
    const int j = std::min(int(f), J - 2);
    const double t = f - j;
    for (size_t q = 0; q < A.size(); ++q) a[q] = A[q][j] + (A[q][j + 1] - A[q][j]) * t;
  }
};

KernelBasis MakeKernelBasis(const Multipole& mp, const Offsets& off, double ap, double lo,
                            double hi, double tol, int max_terms) {
  KernelBasis kb;
  kb.lo = lo;
  if (hi <= lo * (1 + 1e-6)) {  // one thickness: the kernel itself
    kb.B = {KernelValues(mp, off, ap, lo)};
    kb.A = {{1.0}};
    return kb;
  }
  kb.J = 48, kb.log_ratio = std::log(hi / lo);
  const int J = kb.J;
  const size_t n = off.ring.size();
  auto dj = [&](double j) { return lo * std::exp(kb.log_ratio * j / (J - 1)); };
  std::vector<std::vector<double>> K(J), M(J - 1);  // samples and midpoints
  Eigen::MatrixXd N(J, n);
  ParallelFor(0, 2 * J - 1, [&](int64_t b, int64_t e) {
    for (int64_t s = b; s < e; ++s) {
      if (s % 2) {
        M[s / 2] = KernelValues(mp, off, ap, dj(s / 2 + 0.5));
        continue;
      }
      const int j = int(s / 2);
      K[j] = KernelValues(mp, off, ap, dj(j));
      const double g = Sum(K[j]);
      for (size_t i = 0; i < n; ++i) N(j, i) = K[j][i] / g;
    }
  });
  // Right singular vectors from the J × J Gram matrix: N Nᵀ u = λ u, B = Nᵀ u / √λ.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(N * N.transpose());
  const Eigen::VectorXd lambda = es.eigenvalues().reverse();
  const Eigen::MatrixXd U = es.eigenvectors().rowwise().reverse();
  const int qmax = std::min({max_terms, J, int(n)});
  std::vector<std::vector<double>> B, A;
  for (int q = 0; q < qmax && lambda(q) > 1e-300; ++q) {
    const Eigen::VectorXd b = N.transpose() * U.col(q) / std::sqrt(lambda(q));
    B.emplace_back(b.data(), b.data() + n);
    std::vector<double> a(J);
    for (int j = 0; j < J; ++j)
      for (size_t i = 0; i < n; ++i) a[j] += K[j][i] * B.back()[i];
    A.push_back(std::move(a));
    // Worst relative L1 reconstruction error with these q + 1 terms.
    double worst = 0;
    std::vector<double> rec(n);
    for (int s = 0; s < 2 * J - 1; ++s) {
      const std::vector<double>& ref = s % 2 == 0 ? K[s / 2] : M[s / 2];
      std::fill(rec.begin(), rec.end(), 0.0);
      for (size_t qq = 0; qq < B.size(); ++qq) {
        const double c = s % 2 == 0 ? A[qq][s / 2] : 0.5 * (A[qq][s / 2] + A[qq][s / 2 + 1]);
        for (size_t i = 0; i < n; ++i) rec[i] += c * B[qq][i];
      }
      double e = 0;
      for (size_t i = 0; i < n; ++i) e += std::abs(rec[i] - ref[i]);
      worst = std::max(worst, e / Sum(ref));
    }
    kb.error = worst;
    if (worst <= tol) break;
  }
  kb.B = std::move(B), kb.A = std::move(A);
  return kb;
}

}  // namespace

StatusOr<TranslucencyResult> PrecomputeTranslucencyFast(const TransportInput& in,
                                                        const TranslucencyOptions& o) {
  auto prep = Prepare(in, o);
  if (!prep.ok()) return prep.status();
  const Prepared& p = *prep;
  const Multipole& mp = *p.mp;
  const int nd = o.directions;
  const auto dirs = Directions(in, nd);
  const double wproj = Hl2ProjectionWeight(nd);

  // 1. Project first: ε_i = (2π/N_L) Σ_m ℋ_i(ω_m) E(·, ω_m); signal 3 is ρ (for the response).
  // Leaf texels are gathered into compact SoA blocks that stay in cache across the directions.
  std::vector<std::vector<float>> sig(4, std::vector<float>(p.n, 0.0f));
  std::vector<int64_t> leaf_texels;
  for (int64_t i = 0; i < p.n; ++i)
    if (p.inside[i] && p.rho[i] > 0) leaf_texels.push_back(i);
  const int slices = in.horizon && !in.horizon->empty() ? in.horizon->channels() : 0;
  constexpr int64_t kBlock = 1024;
  std::vector<ProjectionDirection> pdirs(nd);
  for (int m = 0; m < nd; ++m) {
    const Direction& d = dirs[m];
    ProjectionDirection& q = pdirs[m];
    q.wx = float(d.w.x), q.wy = float(d.w.y), q.wz = float(d.w.z);
    q.elevation = d.elevation, q.k0 = d.k0, q.k1 = d.k1, q.t = d.t;
    q.shadow = slices > 0 && d.w.z < 1 - 1e-9;
    for (int i = 0; i < 3; ++i) q.c[i] = float(wproj * d.hl2[i]);
  }
  ParallelFor(
      0, int64_t(leaf_texels.size()),
      [&](int64_t b, int64_t e) {
        std::vector<float> nx(kBlock), ny(kBlock), nz(kBlock), rho(kBlock), hz(kBlock * slices),
            s0(kBlock), s1(kBlock), s2(kBlock);
        for (int64_t b0 = b; b0 < e; b0 += kBlock) {
          const int64_t n = std::min(kBlock, e - b0);
          for (int64_t j = 0; j < n; ++j) {
            const int64_t i = leaf_texels[b0 + j];
            nx[j] = in.normal ? in.normal->Plane(0)[i] : 0.0f;
            ny[j] = in.normal ? in.normal->Plane(1)[i] : 0.0f;
            nz[j] = in.normal ? in.normal->Plane(2)[i] : 1.0f;
            rho[j] = p.rho[i];
            for (int k = 0; k < slices; ++k) hz[k * kBlock + j] = in.horizon->Plane(k)[i];
            s0[j] = s1[j] = s2[j] = 0;
          }
          ProjectIrradianceBlock(nx.data(), ny.data(), nz.data(), rho.data(), hz.data(), kBlock, n,
                                 pdirs, s0.data(), s1.data(), s2.data());
          for (int64_t j = 0; j < n; ++j) {
            const int64_t i = leaf_texels[b0 + j];
            sig[0][i] = s0[j], sig[1][i] = s1[j], sig[2][i] = s2[j], sig[3][i] = rho[j];
          }
        }
      },
      kBlock);

  // 2. The kernel family as a few thickness-separable terms; per-texel coefficients.
  const Offsets off = DiskOffsets(p.radius, in.mm_per_texel);
  TranslucencyResult r;
  const KernelBasis kb =
      MakeKernelBasis(mp, off, p.ap, p.d_lo, p.d_hi, o.kernel_tolerance, o.max_kernel_terms);
  const int nq = int(kb.B.size());
  r.kernel_terms = nq, r.kernel_error = kb.error;
  if (kb.error > o.kernel_tolerance)
    r.warnings.push_back(Warning(WarningCode::kThicknessExpansion,
                                 "the kernel's thickness expansion reached " + std::to_string(nq) +
                                     " terms with a relative L1 error of " +
                                     std::to_string(kb.error) + ", above the tolerance " +
                                     std::to_string(o.kernel_tolerance) +
                                     " (raise max_kernel_terms)"));
  std::vector<float> coef(size_t(nq) * p.n);
  ParallelFor(
      0, p.n,
      [&](int64_t b, int64_t e) {
        std::vector<double> a(nq);
        for (int64_t i = b; i < e; ++i) {
          if (!p.inside[i]) continue;
          kb.At(p.d[i], a.data());
          for (int q = 0; q < nq; ++q) coef[size_t(q) * p.n + i] = float(a[q]);
        }
      },
      4096);

  // 3. L = Σ_q B_q ∗ (A_q(d) · signal): FFT convolutions, spectra summed over the terms, one
  // inverse per signal. Zero padding of R texels on one side suffices for a linear result.
  const int R = p.radius;
  // Only the leaf's bounding box is transformed (sources and outputs both lie inside it).
  int x0 = p.w, y0 = p.h, x1 = -1, y1 = -1;
  for (int y = 0; y < p.h; ++y)
    for (int x = 0; x < p.w; ++x)
      if (p.inside[int64_t(y) * p.w + x])
        x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  r.hl2_raw = Image(p.w, p.h, 3), r.response = Image(p.w, p.h, 1);
  if (x1 < 0) {  // empty mask
    Finish(p, &r);
    return r;
  }
  const int bw = x1 - x0 + 1, bh = y1 - y0 + 1;
  const int fw = cv::getOptimalDFTSize(bw + R), fh = cv::getOptimalDFTSize(bh + R);
  std::vector<cv::Mat> kspec(nq);
  ParallelFor(0, nq, [&](int64_t b, int64_t e) {
    for (int64_t q = b; q < e; ++q) {
      cv::Mat kern = cv::Mat::zeros(fh, fw, CV_32F);
      for (size_t i = 0; i < off.ring.size(); ++i)
        kern.at<float>((off.dy[i] + fh) % fh, (off.dx[i] + fw) % fw) = float(kb.B[q][i]);
      cv::dft(kern, kspec[q], 0);
    }
  });
  std::vector<cv::Mat> outs(4);
  ParallelFor(0, 4, [&](int64_t b, int64_t e) {
    for (int64_t s = b; s < e; ++s) {
      cv::Mat acc = cv::Mat::zeros(fh, fw, CV_32F), in_pad = cv::Mat::zeros(fh, fw, CV_32F);
      cv::Mat spec, prod;
      for (int q = 0; q < nq; ++q) {
        const float* c = coef.data() + size_t(q) * p.n;
        for (int y = 0; y < bh; ++y) {
          float* row = in_pad.ptr<float>(y);
          const int64_t at = int64_t(y + y0) * p.w + x0;
          const float* sv = sig[s].data() + at;
          const float* cq = c + at;
          for (int x = 0; x < bw; ++x) row[x] = sv[x] * cq[x];
        }
        cv::dft(in_pad, spec, 0, bh);
        cv::mulSpectrums(spec, kspec[q], prod, 0);
        cv::add(acc, prod, acc);
      }
      cv::dft(acc, outs[s], cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT, bh);
    }
  });
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const int64_t i = int64_t(y) * p.w + x;
      if (!p.inside[i]) continue;
      for (int c = 0; c < 3; ++c) r.hl2_raw.Plane(c)[i] = outs[c].at<float>(y - y0, x - x0);
      r.response.Plane(0)[i] = outs[3].at<float>(y - y0, x - x0);
    }
  Finish(p, &r);
  return r;
}

}  // namespace matfit::leaf
