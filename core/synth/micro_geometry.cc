#include "core/synth/micro_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/synth/random.h"

namespace matfit::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Height at a fractional facet position (bilinear, wrapping around the periodic field).
float HeightAt(const MicroSurface& s, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const double ax = x - fx, ay = y - fy;
  const auto wrap = [](int64_t i, int n) { return int((i % n + n) % n); };
  const int x0 = wrap(int64_t(fx), s.mw), x1 = wrap(int64_t(fx) + 1, s.mw);
  const int y0 = wrap(int64_t(fy), s.mh), y1 = wrap(int64_t(fy) + 1, s.mh);
  const auto at = [&](int xx, int yy) { return double(s.h[size_t(yy) * s.mw + xx]); };
  return float((1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x1, y0)) +
               ay * ((1 - ax) * at(x0, y1) + ax * at(x1, y1)));
}

// Visibility of direction d (unit, d_z > 0) from facet m through the horizon map: above the
// horizon interpolated between the two nearest azimuths.
bool Visible(const MicroSurface& s, int64_t m, const Vec3& d) {
  const double horizontal = std::hypot(d.x, d.y);
  if (d.z <= 0) return false;
  if (horizontal < 1e-9) return true;
  const int A = s.options.azimuths;
  double a = std::atan2(d.y, d.x) / (2 * kPi) * A;
  if (a < 0) a += A;
  const int a0 = int(a) % A, a1 = (a0 + 1) % A;
  const double t = a - std::floor(a);
  const size_t F = size_t(s.facets());
  const double tan_h = (1 - t) * s.horizon_tan[size_t(a0) * F + size_t(m)] +
                       t * s.horizon_tan[size_t(a1) * F + size_t(m)];
  return d.z / horizontal > tan_h;
}

void BuildHeights(MicroSurface* s, uint64_t seed) {
  const MicroGeometryOptions& o = s->options;
  const int sub = o.sub, S = std::max(s->width, s->height);  // the pattern's period, texels
  s->h.assign(size_t(s->facets()), 0.0f);
  ParallelFor(0, s->mh, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < s->mw; ++x) {
        const double tx = (x + 0.5) / sub, ty = (double(y) + 0.5) / sub;  // texels
        const double u = tx / S, v = ty / S;
        const double meso = o.relief * (2 * Fbm(seed, u, v, 4, 4) - 1);
        // Sub-texel bumps: value noise with one and two cells per texel.
        const double bumps =
            o.bump_height * ((2 * ValueNoise(seed + 1, tx, ty, S) - 1) +
                             0.5 * (2 * ValueNoise(seed + 2, 2 * tx, 2 * ty, 2 * S) - 1));
        s->h[size_t(y) * s->mw + size_t(x)] = float((meso + bumps) * sub);  // facet widths
      }
  });
  s->nx.resize(s->h.size()), s->ny.resize(s->h.size()), s->nz.resize(s->h.size());
  ParallelFor(0, s->mh, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < s->mw; ++x) {
        const auto at = [&](int xx, int64_t yy) {
          return double(s->h[size_t((yy + s->mh) % s->mh) * s->mw + size_t((xx + s->mw) % s->mw)]);
        };
        const double dx = 0.5 * (at(x + 1, y) - at(x - 1, y));
        const double dy_up = 0.5 * (at(x, y - 1) - at(x, y + 1));
        const Vec3 n = Normalize(Vec3(-dx, -dy_up, 1.0));
        const size_t m = size_t(y) * s->mw + size_t(x);
        s->nx[m] = float(n.x), s->ny[m] = float(n.y), s->nz[m] = float(n.z);
      }
  });
}

void BuildAlbedo(MicroSurface* s, uint64_t seed) {
  const int W = s->width, H = s->height, S = std::max(W, H);
  const int64_t T = int64_t(W) * H;
  s->albedo.assign(size_t(3 * T), 0.0f);
  const double base[3] = {0.52, 0.46, 0.39};  // warm grey stone
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double u = (x + 0.5) / S, v = (y + 0.5) / S;
      double k = 0.7 + 0.5 * Fbm(seed + 3, u, v, 8, 3);
      if (Cellular(seed + 4, u, v, std::max(2, S / 6)).distance < 0.22) k *= 0.45;  // dark grains
      for (int c = 0; c < 3; ++c)
        s->albedo[size_t(c * T + int64_t(y) * W + x)] = float(std::min(0.9, base[c] * k));
    }
}

// Per facet and azimuth: the steepest rise of the field along that azimuth within the reach.
void BuildHorizon(MicroSurface* s) {
  const int A = s->options.azimuths;
  const int reach = std::max(1, int(std::lround(s->options.reach_texels * s->options.sub)));
  const size_t F = size_t(s->facets());
  s->horizon_tan.assign(size_t(A) * F, 0.0f);
  ParallelFor(0, s->mh, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < s->mw; ++x) {
        const size_t m = size_t(y) * s->mw + size_t(x);
        const double h0 = s->h[m];
        for (int a = 0; a < A; ++a) {
          const double phi = 2 * kPi * a / A;
          const double cx = std::cos(phi), cy = -std::sin(phi);  // rows grow downward
          double best = -std::numeric_limits<double>::infinity();
          for (int d = 1; d <= reach; ++d)
            best = std::max(best, (HeightAt(*s, x + d * cx, double(y) + d * cy) - h0) / d);
          s->horizon_tan[size_t(a) * F + m] = float(best);
        }
      }
  });
}

// Cosine-distributed gather rays from every facet, marched through the field: the facet hit.
void BuildBounce(MicroSurface* s, uint64_t seed) {
  const int K = s->options.bounce_rays;
  const double reach = s->options.reach_texels * s->options.sub;
  const size_t F = size_t(s->facets());
  const float top = *std::max_element(s->h.begin(), s->h.end());
  s->bounce.assign(size_t(K) * F, -1);
  ParallelFor(0, s->mh, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < s->mw; ++x) {
        const size_t m = size_t(y) * s->mw + size_t(x);
        const Vec3 n(s->nx[m], s->ny[m], s->nz[m]);
        // Tangent frame around n.
        const Vec3 t =
            Normalize(std::abs(n.x) < 0.9 ? Cross(n, Vec3(1, 0, 0)) : Cross(n, Vec3(0, 1, 0)));
        const Vec3 b = Cross(n, t);
        const double rotation = HashUniform(seed + 5, m);
        for (int k = 0; k < K; ++k) {
          // Stratified in cos²θ, golden-ratio azimuths rotated per facet.
          const double u1 = (k + 0.5) / K;
          const double phi = 2 * kPi * (rotation + k * 0.6180339887498949);
          const double r = std::sqrt(u1);
          const Vec3 d =
              Normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(1 - u1));
          const double horizontal = std::hypot(d.x, d.y);
          if (horizontal < 1e-6) continue;       // straight up: the sky
          const double step = 0.5 / horizontal;  // half a facet sideways per step
          for (double tt = step; tt * horizontal <= reach; tt += step) {
            const double px = x + tt * d.x, py = double(y) - tt * d.y, pz = s->h[m] + tt * d.z;
            if (pz > top) break;  // above every facet: escaped
            if (pz < HeightAt(*s, px, py)) {
              const int hx = int(((std::lround(px) % s->mw) + s->mw) % s->mw);
              const int hy = int(((std::lround(py) % s->mh) + s->mh) % s->mh);
              s->bounce[size_t(k) * F + m] = int32_t(hy * s->mw + hx);
              break;
            }
          }
        }
      }
  });
}

}  // namespace

bool MicroGeometryOptions::Check(std::string* why) const {
  if (sub < 1 || sub > 16) return *why = "micro-geometry: sub must be in [1, 16]", false;
  if (azimuths < 8 || azimuths > 64)
    return *why = "micro-geometry: azimuths must be in [8, 64]", false;
  if (bounce_rays < 1 || bounce_rays > 64)
    return *why = "micro-geometry: bounce_rays must be in [1, 64]", false;
  if (!(bump_height >= 0 && bump_height <= 4) || !(relief >= 0 && relief <= 64))
    return *why = "micro-geometry: bump_height must be in [0, 4] and relief in [0, 64] texels",
           false;
  if (!(reach_texels > 0 && reach_texels <= 16))
    return *why = "micro-geometry: reach_texels must be in (0, 16]", false;
  if (!(ior >= 1 && ior <= 4) || !(lobe_exponent >= 1 && lobe_exponent <= 1e4))
    return *why = "micro-geometry: ior must be in [1, 4] and lobe_exponent in [1, 1e4]", false;
  return true;
}

StatusOr<MicroSurface> MakeMicroSurface(int width, int height, uint64_t seed,
                                        const MicroGeometryOptions& options) {
  std::string why;
  if (!options.Check(&why)) return InvalidArgument(why);
  // Each facet keeps its horizon and bounce tables (about 4 · (5 + azimuths + bounce_rays) bytes):
  // 512² texels of 4² facets take 650 MB.
  if (width < 4 || height < 4 || width > 512 || height > 512)
    return InvalidArgument(
        "micro-geometry materials are at most 512 texels per side (their "
        "micro-facet tables grow with the square), got " +
        std::to_string(width) + "x" + std::to_string(height) + "; use --size 512 or less");
  MicroSurface s;
  s.width = width, s.height = height, s.options = options;
  s.mw = width * options.sub, s.mh = height * options.sub;
  BuildHeights(&s, seed);
  BuildAlbedo(&s, seed);
  BuildHorizon(&s);
  BuildBounce(&s, seed);
  return s;
}

void RenderMicroLight(const MicroSurface& s, const Vec3& light, const Vec3& view, float* out) {
  const MicroGeometryOptions& o = s.options;
  const int W = s.width, H = s.height, sub = o.sub, K = o.bounce_rays;
  const int64_t T = int64_t(W) * H;
  const size_t F = size_t(s.facets());
  const Vec3 l = Normalize(light), v = Normalize(view);
  // Direct irradiance of every facet: E = max(0, n·l) · V_l.
  std::vector<float> E(F, 0.0f);
  ParallelFor(0, s.mh, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < s.mw; ++x) {
        const size_t m = size_t(y) * s.mw + size_t(x);
        const double cos_i = s.nx[m] * l.x + s.ny[m] * l.y + s.nz[m] * l.z;
        if (cos_i <= 0 || l.z <= 0) continue;
        if (o.shadows && !Visible(s, int64_t(m), l)) continue;
        E[m] = float(cos_i);
      }
  });
  const auto texel_of = [&](size_t m) {
    return int64_t(m / size_t(s.mw)) / sub * W + int64_t(m % size_t(s.mw)) / sub;
  };
  const double f0 = std::pow((o.ior - 1) / (o.ior + 1), 2), e = o.lobe_exponent;
  ParallelFor(0, H, [&](int64_t ty0, int64_t ty1) {
    for (int64_t ty = ty0; ty < ty1; ++ty)
      for (int tx = 0; tx < W; ++tx) {
        const int64_t p = ty * W + tx;
        double sum[3] = {0, 0, 0}, weight = 0;
        for (int j = 0; j < sub; ++j)
          for (int i = 0; i < sub; ++i) {
            const size_t m = size_t(ty * sub + j) * s.mw + size_t(tx * sub + i);
            const Vec3 n(s.nx[m], s.ny[m], s.nz[m]);
            const double cos_v = Dot(n, v);
            // Projected area towards the view per unit of plane area, if the view reaches it.
            if (cos_v <= 0 || (o.masking && !Visible(s, int64_t(m), v))) continue;
            const double w = cos_v / n.z;
            double bounce[3] = {0, 0, 0};
            if (o.bounce)
              for (int k = 0; k < K; ++k) {
                const int32_t hit = s.bounce[size_t(k) * F + m];
                if (hit < 0 || E[size_t(hit)] == 0) continue;
                const int64_t q = texel_of(size_t(hit));
                for (int c = 0; c < 3; ++c)
                  bounce[c] += s.albedo[size_t(c * T + q)] * E[size_t(hit)];
              }
            double spec = 0;
            if (o.specular && E[m] > 0) {
              const double cos_i = Dot(n, l);
              const Vec3 r = n * (2 * cos_i) - l;
              const double cos_r = std::max(0.0, Dot(r, v));
              const double fresnel = f0 + (1 - f0) * std::pow(1 - cos_i, 5);
              spec = fresnel * (e + 2) / 2 * std::pow(cos_r, e) * E[m];
            }
            for (int c = 0; c < 3; ++c)
              sum[c] += w * (s.albedo[size_t(c * T + p)] * (E[m] + bounce[c] / K) + spec);
            weight += w;
          }
        for (int c = 0; c < 3; ++c)
          out[size_t(c * T + p)] = weight > 0 ? float(sum[c] / weight) : 0.0f;
      }
  });
}

LightStack RenderMicroStack(const MicroSurface& s, const std::vector<LightSample>& lights,
                            const Vec3& view, const ProgressFn& progress) {
  const int n = int(lights.size());
  LightStack stack(s.width, s.height, 3, n);
  stack.lights() = lights;
  stack.view_direction = Normalize(view);
  AnglesDegFromDirection(stack.view_direction, &stack.view_theta_deg, &stack.view_phi_deg);
  const int64_t T = int64_t(s.width) * s.height;
  std::vector<float> planes(size_t(3 * T));
  for (int i = 0; i < n; ++i) {  // each light is parallel inside
    RenderMicroLight(s, lights[size_t(i)].direction, view, planes.data());
    for (int c = 0; c < 3; ++c) {
      float* dst = stack.Plane(i, c).data();
      const float intensity = float(lights[size_t(i)].intensity[c]);
      for (int64_t p = 0; p < T; ++p) dst[p] = intensity * planes[size_t(c * T + p)];
    }
    if (progress) progress(i + 1, n);
  }
  return stack;
}

MaterialMaps MicroTruthMaps(const MicroSurface& s) {
  const int W = s.width, H = s.height, sub = s.options.sub;
  const int64_t T = int64_t(W) * H;
  MaterialMaps m;
  m.width = W, m.height = H;
  m.model = ModelId("lambert");
  m.albedo = Image(W, H, 3);
  m.normal = Image(W, H, 3);
  m.height_map = Image(W, H, 1);
  m.mask = Image(W, H, 1, 1.0f);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      // The macro normal: that of the texel's mean slope, Σ (n_x, n_y) / n_z over its facets.
      double gx = 0, gy = 0, hsum = 0;
      for (int j = 0; j < sub; ++j)
        for (int i = 0; i < sub; ++i) {
          const size_t f = size_t(y * sub + j) * s.mw + size_t(x * sub + i);
          gx += s.nx[f] / s.nz[f], gy += s.ny[f] / s.nz[f], hsum += s.h[f];
        }
      const double k = 1.0 / (sub * sub);
      const Vec3 n = Normalize(Vec3(gx * k, gy * k, 1.0));
      m.normal.At(0, y, x) = float(n.x), m.normal.At(1, y, x) = float(n.y);
      m.normal.At(2, y, x) = float(n.z);
      m.height_map.At(0, y, x) = float(hsum * k / sub);  // texels
      for (int c = 0; c < 3; ++c)
        m.albedo.At(c, y, x) = s.albedo[size_t(c * T + int64_t(y) * W + x)];
    }
  return m;
}

}  // namespace matfit::synth
