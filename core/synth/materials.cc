#include "core/synth/materials.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/shading/shading.h"
#include "core/synth/micro_geometry.h"
#include "core/synth/random.h"

namespace matfit::synth {
namespace {

constexpr double kPi = std::numbers::pi;

struct Texel {
  double height = 0;  // in sample widths (scaled to texels later)
  double albedo[3] = {0, 0, 0};
  double specular = 0, exponent = 0, roughness = 0;
  double thickness = 0, translucency[3] = {0, 0, 0}, mask = 1;
};
using TexelFn = std::function<Texel(double u, double v)>;

double Smoothstep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Rounded thread profile across one period: 1 at the centre, 0 at the edges.
double ThreadProfile(double f) { return std::sqrt(std::max(0.0, 1.0 - (2 * f - 1) * (2 * f - 1))); }

TexelFn Plaster(uint64_t seed) {
  return [=](double u, double v) {
    Texel t;
    t.height = 0.004 * Fbm(seed, u, v, 8, 4);
    const double g = 0.05 * (Fbm(seed + 1, u, v, 16, 3) - 0.5);
    t.albedo[0] = 0.78 + g, t.albedo[1] = 0.76 + g, t.albedo[2] = 0.72 + g;
    return t;
  };
}

TexelFn Plastic(uint64_t seed, bool cook_torrance) {
  return [=](double u, double v) {
    Texel t;
    t.height =
        0.03 * Fbm(seed, u, v, 4, 3);  // moulded relief: slopes to ~25°, shadows at grazing light
    const double w = Smoothstep(0.45, 0.55, Fbm(seed + 2, u, v, 3, 2));
    t.albedo[0] = 0.55 * (1 - w) + 0.08 * w;
    t.albedo[1] = 0.10 * (1 - w) + 0.20 * w;
    t.albedo[2] = 0.08 * (1 - w) + 0.50 * w;
    if (cook_torrance) {
      t.specular = shading::F0FromIor(1.5);
      t.roughness = 0.35;
    } else {
      t.specular = 0.35;
      t.exponent = 40;
    }
    return t;
  };
}

// Lacquered panel (multi-view BTFs, issue 17): Cook–Torrance whose F0 (0.03–0.08, IOR
// 1.42–1.79) and roughness (0.2–0.5) vary over the surface in independent smooth patches, so a
// fit must recover them per texel; plastic's relief.
TexelFn Lacquer(uint64_t seed) {
  return [=](double u, double v) {
    Texel t;
    t.height = 0.03 * Fbm(seed, u, v, 4, 3);
    const double w = Smoothstep(0.4, 0.6, Fbm(seed + 2, u, v, 3, 2));
    t.albedo[0] = 0.30 * (1 - w) + 0.06 * w;
    t.albedo[1] = 0.16 * (1 - w) + 0.22 * w;
    t.albedo[2] = 0.06 * (1 - w) + 0.35 * w;
    t.specular = 0.03 + 0.05 * Smoothstep(0.3, 0.7, Fbm(seed + 5, u, v, 2, 2));
    t.roughness = 0.2 + 0.3 * Smoothstep(0.3, 0.7, Fbm(seed + 7, u, v, 3, 2));
    return t;
  };
}

TexelFn Wool(uint64_t seed) {
  constexpr int kThreads = 16;  // threads per sample width in each direction
  return [=](double u, double v) {
    Texel t;
    const double x = u * kThreads, y = v * kThreads;
    const int ix = int(std::floor(x)), iy = int(std::floor(y));
    const double fx = x - ix, fy = y - iy;
    // Plain weave: the warp (along v) passes over where (ix + iy) is even.
    const double over = ((ix + iy) & 1) ? -1.0 : 1.0;
    const double warp = ThreadProfile(fx) * (0.6 + 0.4 * over * std::cos(kPi * (fy - 0.5)));
    const double weft = ThreadProfile(fy) * (0.6 - 0.4 * over * std::cos(kPi * (fx - 0.5)));
    const double fuzz = Fbm(seed, u, v, 64, 2);
    t.height = 0.02 * (std::max(warp, weft) * 0.9 + 0.1 * fuzz);  // thread height 0.32 × width
    const double tint = 0.08 * (HashUniform(seed, warp > weft ? ix : 1000 + iy, 7) - 0.5);
    t.albedo[0] = 0.55 + tint, t.albedo[1] = 0.45 + tint, t.albedo[2] = 0.33 + tint;
    t.specular = 0.04;
    t.exponent = 8;
    return t;
  };
}

TexelFn Corduroy(uint64_t seed) {
  constexpr int kWales = 12;  // ridges per sample width, running along y
  return [=](double u, double v) {
    Texel t;
    const double f = u * kWales - std::floor(u * kWales);
    const double ridge = std::pow(ThreadProfile(f), 0.6);
    t.height = 0.025 * ridge + 0.0015 * Fbm(seed, u, v, 48, 2);
    const double pile = 0.05 * (Fbm(seed + 3, u, v, 32, 2) - 0.5);
    t.albedo[0] = 0.16 + 0.05 * ridge + pile;
    t.albedo[1] = 0.20 + 0.05 * ridge + pile;
    t.albedo[2] = 0.38 + 0.06 * ridge + pile;
    t.specular = 0.06;
    t.exponent = 12;
    return t;
  };
}

TexelFn Granite(uint64_t seed) {
  static constexpr double kPalette[4][3] = {
      {0.06, 0.06, 0.07}, {0.30, 0.30, 0.31}, {0.55, 0.38, 0.33}, {0.68, 0.67, 0.64}};
  return [=](double u, double v) {
    Texel t;
    const CellSample c = Cellular(seed, u, v, 24);
    const int mineral = int(HashUniform(seed, c.cell_id, 3) * 4) & 3;
    const double grain = 0.06 * (Fbm(seed + 5, u, v, 64, 2) - 0.5);
    for (int k = 0; k < 3; ++k) t.albedo[k] = std::clamp(kPalette[mineral][k] + grain, 0.0, 1.0);
    t.height = 0.0006 * Fbm(seed + 6, u, v, 16, 3);
    t.specular = 0.3;
    t.exponent = 128;
    return t;
  };
}

TexelFn Leaf(uint64_t seed) {
  return [=](double u, double v) {
    Texel t;
    // Leaf axis along y from (0.5, 0.08) to (0.5, 0.92); half-width profile sin-shaped.
    const double s = (v - 0.08) / 0.84;  // 0..1 along the axis (row order)
    const double half =
        0.36 * std::pow(std::max(0.0, std::sin(kPi * std::clamp(s, 0.0, 1.0))), 0.8);
    const double dx = u - 0.5;
    const double inside = (s > 0 && s < 1) ? Smoothstep(0.004, -0.004, std::abs(dx) - half) : 0.0;
    t.mask = inside > 0.5 ? 1 : 0;
    // Veins: midrib plus secondary veins leaving it at ~50° toward the tip.
    const double mid = std::exp(-std::pow(dx / 0.008, 2));
    const double sec_phase = (s - 1.6 * std::abs(dx)) * 9.0;
    const double sec = std::exp(-std::pow((sec_phase - std::round(sec_phase)) / 0.07, 2)) *
                       Smoothstep(0.0, 0.02, std::abs(dx)) *
                       (half > 0 ? Smoothstep(half, 0.6 * half, std::abs(dx)) : 0);
    const double vein = std::max(mid, 0.6 * sec);
    const double blade = 0.003 * Fbm(seed, u, v, 8, 3);
    t.height =
        inside * (0.008 * mid + 0.003 * sec + blade + 0.01 * (1 - std::pow(2 * dx / 0.72, 2)));
    const double mottle = 0.04 * (Fbm(seed + 9, u, v, 12, 3) - 0.5);
    const double leafc[3] = {0.10 + mottle, 0.30 + mottle, 0.05}, veinc[3] = {0.28, 0.42, 0.14};
    for (int k = 0; k < 3; ++k)
      t.albedo[k] = inside * (leafc[k] * (1 - vein) + veinc[k] * vein) + (1 - inside) * 0.02;
    t.thickness = inside * (0.20 + 0.30 * mid + 0.08 * sec + 0.02 * Fbm(seed + 4, u, v, 16, 2));
    // Translucency: green transmission, attenuated where the leaf is thicker (Beer–Lambert).
    const double att = std::exp(-4.0 * std::max(0.0, t.thickness - 0.2));
    const double tr[3] = {0.20, 0.45, 0.08};
    for (int k = 0; k < 3; ++k) t.translucency[k] = inside * tr[k] * att;
    t.specular = inside * shading::F0FromIor(1.45);
    t.roughness = 0.35;
    return t;
  };
}

const std::vector<MaterialInfo> kMaterials = {
    {"plaster", "matte plaster: Lambertian with fBm bumps", false},
    {"plastic", "glossy moulded plastic: Blinn-Phong k_s 0.35, e 40", false},
    {"plastic-ct", "glossy plastic: Cook-Torrance GGX, F0 0.04, roughness 0.35", false},
    {"lacquer", "lacquered panel: Cook-Torrance GGX, F0 0.03-0.08 and roughness 0.2-0.5 varying",
     false},
    {"wool", "plain-weave wool-like fabric with self-shadowing", true},
    {"corduroy", "corduroy-like ridged fabric with self-shadowing", true},
    {"granite", "speckled polished granite-like stone: Blinn-Phong e 128", false},
    {"leaf", "veined leaf with thickness and translucency maps: Cook-Torrance", false},
    {"micro-stone",
     "stone rendered from sub-texel micro-geometry: ray-traced shadowing, masking, one bounce",
     false, true},
};

}  // namespace

const std::vector<MaterialInfo>& Materials() { return kMaterials; }

const MaterialInfo* FindMaterial(const std::string& name) {
  for (const auto& m : kMaterials)
    if (m.name == name) return &m;
  return nullptr;
}

Image NormalsFromHeight(const Image& h) {
  const int w = h.width(), ht = h.height();
  Image n(w, ht, 3);
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) {
      const double dx = 0.5 * (h.At(0, y, (x + 1) % w) - h.At(0, y, (x + w - 1) % w));
      const double dy_up = 0.5 * (h.At(0, (y + ht - 1) % ht, x) - h.At(0, (y + 1) % ht, x));
      const Vec3 nn = Normalize(Vec3(-dx, -dy_up, 1.0));
      n.At(0, y, x) = float(nn.x), n.At(1, y, x) = float(nn.y), n.At(2, y, x) = float(nn.z);
    }
  return n;
}

StatusOr<MaterialMaps> MakeMaterial(const std::string& name, int size, uint64_t seed) {
  if (!FindMaterial(name)) {
    std::string list;
    for (const auto& m : kMaterials) list += (list.empty() ? "" : ", ") + m.name;
    return InvalidArgument("--material '" + name + "' is unknown; choose one of: " + list);
  }
  if (size < 4 || size > 8192)
    return InvalidArgument("--size must be in [4, 8192], got " + std::to_string(size));
  if (FindMaterial(name)->micro_geometry) {
    auto surface = MakeMicroSurface(size, size, seed);
    if (!surface.ok()) return surface.status();
    return MicroTruthMaps(*surface);
  }
  TexelFn fn;
  MaterialMaps m;
  m.width = m.height = size;
  const char* model = "blinn-phong";
  if (name == "plaster")
    fn = Plaster(seed), model = "lambert";
  else if (name == "plastic")
    fn = Plastic(seed, false);
  else if (name == "plastic-ct")
    fn = Plastic(seed, true), model = "cook-torrance";
  else if (name == "lacquer")
    fn = Lacquer(seed), model = "cook-torrance";
  else if (name == "wool")
    fn = Wool(seed);
  else if (name == "corduroy")
    fn = Corduroy(seed);
  else if (name == "granite")
    fn = Granite(seed);
  else
    fn = Leaf(seed), model = "cook-torrance";
  m.model = ModelId(model);
  const ModelDescriptor& truth_model = Model(m.model);
  const bool leaf = name == "leaf";

  m.albedo = Image(size, size, 3);
  m.height_map = Image(size, size, 1);
  m.mask = Image(size, size, 1, 1.0f);
  truth_model.InitTruthMaps(size, size, &m);
  if (leaf) m.thickness = Image(size, size, 1), m.translucency = Image(size, size, 3);
  ParallelFor(0, size, [&](int64_t y0, int64_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < size; ++x) {
        // Texel centres; v grows with the row index (patterns are symmetric in orientation).
        const Texel t = fn((x + 0.5) / size, (y + 0.5) / size);
        m.height_map.At(0, y, x) = float(t.height * size);  // sample widths → texels
        for (int c = 0; c < 3; ++c) m.albedo.At(c, y, x) = float(t.albedo[c]);
        m.mask.At(0, y, x) = float(t.mask);
        truth_model.SetTruthTexel(x, y, {t.specular, t.exponent, t.roughness}, &m);
        if (leaf) {
          m.thickness.At(0, y, x) = float(t.thickness);
          for (int c = 0; c < 3; ++c) m.translucency.At(c, y, x) = float(t.translucency[c]);
        }
      }
  });
  m.normal = NormalsFromHeight(m.height_map);
  return m;
}

StatusOr<MaterialMaps> MakeMaterial(const std::string& name, int width, int height, uint64_t seed) {
  if (height < 4 || height > 8192)
    return InvalidArgument("--size height must be in [4, 8192], got " + std::to_string(height));
  auto m = MakeMaterial(name, std::max(width, height), seed);
  if (!m.ok() || width == height) return m;
  auto crop = [&](Image& img) {
    if (img.empty()) return;
    Image out(width, height, img.channels());
    for (int c = 0; c < img.channels(); ++c)
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) out.At(c, y, x) = img.At(c, y, x);
    img = std::move(out);
  };
  for (Image* img : {&m->albedo, &m->normal, &m->height_map, &m->mask, &m->specular, &m->exponent,
                     &m->roughness, &m->thickness, &m->translucency})
    crop(*img);
  m->width = width, m->height = height;
  return m;
}

}  // namespace matfit::synth
