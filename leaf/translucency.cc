#include "leaf/translucency.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>

#include "core/parallel.h"
#include "leaf/hl2.h"
#include "leaf/horizon.h"

namespace matfit::leaf {

bool TranslucencyOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!multipole.Check(why)) return false;
  if (directions < 3 || directions > 65536)
    return fail("directions (N_L) must be in 3..65536, got " + std::to_string(directions));
  if (!(kernel_threshold > 0)) return fail("kernel_threshold must be > 0");
  if (max_kernel_radius < 1 || max_kernel_radius > 1024)
    return fail("max_kernel_radius must be in 1..1024 texels");
  if (!(bucket_tolerance > 0 && bucket_tolerance < 1))
    return fail("bucket_tolerance must be in (0, 1)");
  if (max_buckets < 2 || max_buckets > 1024) return fail("max_buckets must be in 2..1024");
  return true;
}

namespace {

constexpr double kPi = std::numbers::pi;

// Everything both methods derive from the input before transport.
struct Prepared {
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

StatusOr<Prepared> Prepare(const TransportInput& in, const TranslucencyOptions& o,
                           const Multipole& mp) {
  MATFIT_RETURN_IF_ERROR(Validate(in, o));
  Prepared p;
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
  p.radius = int(std::ceil(r_mm / in.mm_per_texel));
  if (p.radius > o.max_kernel_radius) p.radius = o.max_kernel_radius, p.cut = true;
  p.radius = std::max(p.radius, 1);
  return p;
}

// Disk of texel offsets with |offset| ≤ radius and their distances in mm.
struct Offsets {
  std::vector<int> dx, dy;
  std::vector<double> r_mm;
};
Offsets DiskOffsets(int radius, double mm) {
  Offsets o;
  for (int y = -radius; y <= radius; ++y)
    for (int x = -radius; x <= radius; ++x)
      if (x * x + y * y <= radius * radius)
        o.dx.push_back(x), o.dy.push_back(y),
            o.r_mm.push_back(mm * std::sqrt(double(x * x + y * y)));
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
                int64_t e, float* out) {
  const float wx = float(dir.w.x), wy = float(dir.w.y), wz = float(dir.w.z);
  const float* nx = in.normal ? in.normal->Plane(0).data() : nullptr;
  const float* ny = in.normal ? in.normal->Plane(1).data() : nullptr;
  const float* nz = in.normal ? in.normal->Plane(2).data() : nullptr;
  const bool shadow = in.horizon && !in.horizon->empty() && dir.w.z < 1 - 1e-9;
  const float* h0 = shadow ? in.horizon->Plane(dir.k0).data() : nullptr;
  const float* h1 = shadow ? in.horizon->Plane(dir.k1).data() : nullptr;
  const float t = dir.t, el = dir.elevation;
  for (int64_t i = b; i < e; ++i) {
    float c = nx ? nx[i] * wx + ny[i] * wy + nz[i] * wz : wz;
    c = c > 0 ? c : 0;
    const float v = shadow ? SoftVisibility(el, h0[i] + (h1[i] - h0[i]) * t) : 1.0f;
    out[i] = p.rho[i] * v * c;
  }
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
    r->warnings.push_back("translucency kernel radius cut to " + std::to_string(p.radius) +
                          " texels (raise max_kernel_radius or use a coarser texel pitch)");
  if (p.thin_texels > 0)
    r->warnings.push_back(std::to_string(p.thin_texels) +
                          " texels thinner than the multipole model's validity (1.5 l) were "
                          "clamped to it and flagged");
}

// Direct gather: out_m(x_o) = A_p Σ T(|x_o − x_i|, d(x_i)) E_m(x_i) for m < nd, plus the
// response R. E is texel-major (E[i·nd + m]); `sink` receives (texel, sums[nd], R).
template <typename Sink>
void DirectSum(const Prepared& p, const Multipole& mp, double mm, const std::vector<float>& E,
               int nd, Sink&& sink) {
  const Offsets off = DiskOffsets(p.radius, mm);
  ParallelFor(
      0, p.h,
      [&](int64_t y0, int64_t y1) {
        std::vector<double> acc(nd);
        for (int64_t y = y0; y < y1; ++y)
          for (int x = 0; x < p.w; ++x) {
            const int64_t o = y * p.w + x;
            if (!p.inside[o]) continue;
            std::fill(acc.begin(), acc.end(), 0.0);
            double resp = 0;
            for (size_t k = 0; k < off.dx.size(); ++k) {
              const int xi = x + off.dx[k], yi = int(y) + off.dy[k];
              if (xi < 0 || yi < 0 || xi >= p.w || yi >= p.h) continue;
              const int64_t i = int64_t(yi) * p.w + xi;
              if (!p.inside[i]) continue;
              const double t = p.ap * mp.Clamped(off.r_mm[k], p.d[i]);
              const float* e = &E[i * nd];
              for (int m = 0; m < nd; ++m) acc[m] += t * e[m];
              resp += t * p.rho[i];
            }
            sink(o, acc.data(), resp);
          }
      },
      1);
}

}  // namespace

StatusOr<TranslucencyResult> PrecomputeTranslucencyReference(const TransportInput& in,
                                                             const TranslucencyOptions& o) {
  MATFIT_RETURN_IF_ERROR(Validate(in, o));
  const Multipole mp(o.multipole);
  auto prep = Prepare(in, o, mp);
  if (!prep.ok()) return prep.status();
  const Prepared& p = *prep;
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
  DirectSum(p, mp, in.mm_per_texel, E, nd, [&](int64_t t, const double* L, double resp) {
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

StatusOr<Image> DirectionalTranslucency(const TransportInput& in, const TranslucencyOptions& o,
                                        const Vec3& w) {
  MATFIT_RETURN_IF_ERROR(Validate(in, o));
  if (!(w.z > 0)) return InvalidArgument("DirectionalTranslucency needs a light with w.z > 0");
  const Multipole mp(o.multipole);
  auto prep = Prepare(in, o, mp);
  if (!prep.ok()) return prep.status();
  const Prepared& p = *prep;
  const int slices = in.horizon && !in.horizon->empty() ? in.horizon->channels() : 0;
  std::vector<float> E(p.n);
  Irradiance(in, p, MakeDirection(Normalize(w), slices), 0, p.n, E.data());
  Image out(p.w, p.h, 1);
  DirectSum(p, mp, in.mm_per_texel, E, 1,
            [&](int64_t t, const double* L, double) { out.Plane(0)[t] = float(L[0]); });
  return out;
}

namespace {

// The discrete kernel A_p max(0, T(r, d)) on the offset disk.
std::vector<double> KernelValues(const Multipole& mp, const Offsets& off, double ap, double d) {
  std::vector<double> k(off.r_mm.size());
  for (size_t i = 0; i < k.size(); ++i) k[i] = ap * mp.Clamped(off.r_mm[i], d);
  return k;
}
double Sum(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s;
}

// Geometric thickness buckets; the energy-rescaled hat interpolation between neighbours must
// stay within `tol` (relative L1) at each midpoint.
std::vector<double> ChooseBuckets(const Multipole& mp, const Offsets& off, double ap, double lo,
                                  double hi, double tol, int max_buckets, double* worst) {
  *worst = 0;
  if (hi <= lo * (1 + 1e-6)) return {lo};
  for (int n = 2;; ++n) {
    std::vector<double> d(n);
    for (int k = 0; k < n; ++k) d[k] = lo * std::pow(hi / lo, double(k) / (n - 1));
    double err = 0;
    for (int k = 0; k + 1 < n; ++k) {
      const double dm = std::sqrt(d[k] * d[k + 1]);
      const auto ka = KernelValues(mp, off, ap, d[k]), kb = KernelValues(mp, off, ap, d[k + 1]);
      const auto km = KernelValues(mp, off, ap, dm);
      const double gm = Sum(km), sa = gm / Sum(ka), sb = gm / Sum(kb);
      double e = 0;
      for (size_t i = 0; i < km.size(); ++i)
        e += std::abs(0.5 * sa * ka[i] + 0.5 * sb * kb[i] - km[i]);
      err = std::max(err, e / gm);
    }
    if (err <= tol || n >= max_buckets) {
      *worst = err;
      return d;
    }
  }
}

}  // namespace

StatusOr<TranslucencyResult> PrecomputeTranslucencyFast(const TransportInput& in,
                                                        const TranslucencyOptions& o) {
  MATFIT_RETURN_IF_ERROR(Validate(in, o));
  const Multipole mp(o.multipole);
  auto prep = Prepare(in, o, mp);
  if (!prep.ok()) return prep.status();
  const Prepared& p = *prep;
  const int nd = o.directions;
  const auto dirs = Directions(in, nd);
  const double wproj = Hl2ProjectionWeight(nd);

  // 1. Project first: ε_i = (2π/N_L) Σ_m ℋ_i(ω_m) E(·, ω_m); signal 3 is ρ (for the response).
  std::vector<std::vector<float>> sig(4, std::vector<float>(p.n, 0.0f));
  ParallelFor(
      0, p.n,
      [&](int64_t b, int64_t e) {
        std::vector<float> tmp(e - b);
        for (int m = 0; m < nd; ++m) {
          Irradiance(in, p, dirs[m], b, e, tmp.data() - b);
          const float c0 = float(wproj * dirs[m].hl2[0]), c1 = float(wproj * dirs[m].hl2[1]),
                      c2 = float(wproj * dirs[m].hl2[2]);
          float *s0 = sig[0].data(), *s1 = sig[1].data(), *s2 = sig[2].data();
          for (int64_t i = b; i < e; ++i) {
            const float v = tmp[i - b];
            s0[i] += c0 * v, s1[i] += c1 * v, s2[i] += c2 * v;
          }
        }
        for (int64_t i = b; i < e; ++i) sig[3][i] = p.rho[i];
      },
      4096);

  // 2. Thickness buckets and the per-texel bucket weights w_k(d)·g(d)/g(d_k).
  const Offsets off = DiskOffsets(p.radius, in.mm_per_texel);
  TranslucencyResult r;
  const auto dk = ChooseBuckets(mp, off, p.ap, p.d_lo, p.d_hi, o.bucket_tolerance, o.max_buckets,
                                &r.kernel_error);
  const int nb = int(dk.size());
  r.buckets = nb;
  std::vector<double> gk(nb);
  for (int k = 0; k < nb; ++k) gk[k] = Sum(KernelValues(mp, off, p.ap, dk[k]));
  // g(d) tabulated on a fine geometric grid (smooth in log d), interpolated per texel.
  const int ng = 257;
  std::vector<double> gtab(ng);
  const double lr = nb > 1 ? std::log(p.d_hi / p.d_lo) : 0;
  for (int j = 0; j < ng; ++j)
    gtab[j] = Sum(KernelValues(mp, off, p.ap, p.d_lo * std::exp(lr * j / (ng - 1))));
  auto bucket_of = [&](float d, int* k, float* wk, float* wk1) {
    if (nb == 1) {
      *k = 0, *wk = 1, *wk1 = 0;
      return;
    }
    const double u = std::clamp(std::log(d / p.d_lo) / lr, 0.0, 1.0);
    const double fg = u * (ng - 1);
    const int jg = std::min(int(fg), ng - 2);
    const double g = gtab[jg] + (gtab[jg + 1] - gtab[jg]) * (fg - jg);
    const double fb = u * (nb - 1);
    *k = std::min(int(fb), nb - 2);
    const double t = fb - *k;
    *wk = float((1 - t) * g / gk[*k]), *wk1 = float(t * g / gk[*k + 1]);
  };

  // 3. FFT convolution per bucket, spectra summed over buckets, one inverse per signal.
  const int R = p.radius;
  const int fw = cv::getOptimalDFTSize(p.w + 2 * R), fh = cv::getOptimalDFTSize(p.h + 2 * R);
  std::vector<cv::Mat> kspec(nb);
  ParallelFor(0, nb, [&](int64_t b, int64_t e) {
    for (int64_t k = b; k < e; ++k) {
      cv::Mat kern = cv::Mat::zeros(fh, fw, CV_32F);
      const auto kv = KernelValues(mp, off, p.ap, dk[k]);
      for (size_t i = 0; i < kv.size(); ++i)
        kern.at<float>((off.dy[i] + fh) % fh, (off.dx[i] + fw) % fw) = float(kv[i]);
      cv::dft(kern, kspec[k], 0);
    }
  });
  std::vector<int> bk(p.n);
  std::vector<float> w0(p.n), w1(p.n);
  for (int64_t i = 0; i < p.n; ++i) bucket_of(p.d[i], &bk[i], &w0[i], &w1[i]);
  std::vector<cv::Mat> outs(4);
  ParallelFor(0, 4, [&](int64_t b, int64_t e) {
    for (int64_t s = b; s < e; ++s) {
      cv::Mat acc = cv::Mat::zeros(fh, fw, CV_32F), in_pad(fh, fw, CV_32F), spec, prod;
      for (int k = 0; k < nb; ++k) {
        in_pad.setTo(0);
        bool any = false;
        for (int y = 0; y < p.h; ++y) {
          float* row = in_pad.ptr<float>(y);
          for (int x = 0; x < p.w; ++x) {
            const int64_t i = int64_t(y) * p.w + x;
            const float v = sig[s][i];
            if (v == 0) continue;
            const float wt = bk[i] == k ? w0[i] : (nb > 1 && bk[i] + 1 == k ? w1[i] : 0.0f);
            row[x] = v * wt;
            any = any || wt != 0;
          }
        }
        if (!any) continue;
        cv::dft(in_pad, spec, 0, p.h);
        cv::mulSpectrums(spec, kspec[k], prod, 0);
        acc += prod;
      }
      cv::dft(acc, outs[s], cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
    }
  });
  r.hl2_raw = Image(p.w, p.h, 3), r.response = Image(p.w, p.h, 1);
  for (int y = 0; y < p.h; ++y)
    for (int x = 0; x < p.w; ++x) {
      const int64_t i = int64_t(y) * p.w + x;
      if (!p.inside[i]) continue;
      for (int c = 0; c < 3; ++c) r.hl2_raw.Plane(c)[i] = outs[c].at<float>(y, x);
      r.response.Plane(0)[i] = outs[3].at<float>(y, x);
    }
  Finish(p, &r);
  return r;
}

}  // namespace matfit::leaf
