#include "leaf/synthetic_scan.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/color.h"
#include "core/model/model.h"
#include "core/synth/materials.h"

namespace matfit::leaf {

bool SyntheticScanOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (width < 64 || height < 64 || width > 4096 || height > 4096)
    return fail("sheet size must be in 64..4096 pixels");
  if (leaf_size < 16 || leaf_size + 24 > std::min(width, height))
    return fail("leaf_size must be ≥ 16 and leave a 12-pixel margin on the sheet");
  if (back_images < 1 || back_images > 32) return fail("back_images must be in 1..32");
  if (!(mm_per_pixel > 0)) return fail("mm_per_pixel must be > 0");
  if (!(marker_mm > 0)) return fail("marker_mm must be > 0");
  return true;
}

namespace {

// Brightness of a near point light at height h above the foot point (fu, fv), sheet
// coordinates in units of the half width: irradiance ∝ h³ / (h² + r²)^{3/2} (cos/r² law).
double NearLight(double u, double v, double fu, double fv, double h) {
  const double r2 = (u - fu) * (u - fu) + (v - fv) * (v - fv);
  return h * h * h / std::pow(h * h + r2, 1.5);
}

float Quantize(float v) {
  const float code = std::round(LinearToSrgb(std::clamp(v, 0.0f, 1.0f)) * 255.0f) / 255.0f;
  return SrgbToLinear(code);
}

}  // namespace

SyntheticScan MakeSyntheticScan(const SyntheticScanOptions& o, const ProgressFn& progress) {
  MATFIT_CHECK(o.Check(nullptr));
  SyntheticScan s;
  const int W = o.width, H = o.height, N = o.leaf_size;
  const int64_t np = int64_t(W) * H;
  auto leafm = synth::MakeMaterial("leaf", N, o.seed);
  MATFIT_CHECK(leafm.ok());
  const MaterialMaps& lm = *leafm;
  s.leaf_x0 = (W - N) / 2, s.leaf_y0 = (H - N) / 2;
  // Sheet-sized truth: leaf inside its square, bare sheet elsewhere.
  MaterialMaps& t = s.truth;
  t.width = W, t.height = H, t.model = ModelId("lambert");
  t.albedo = Image(W, H, 3, 1.0f), t.normal = Image(W, H, 3), t.translucency = Image(W, H, 3, 1.0f);
  t.thickness = Image(W, H, 1), t.mask = Image(W, H, 1);
  for (int64_t i = 0; i < np; ++i) t.normal.Plane(2)[i] = 1;
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < N; ++x) {
      if (lm.mask.At(0, y, x) < 0.5f) continue;
      const int X = s.leaf_x0 + x, Y = s.leaf_y0 + y;
      for (int c = 0; c < 3; ++c) {
        t.albedo.At(c, Y, X) = lm.albedo.At(c, y, x);
        t.normal.At(c, Y, X) = lm.normal.At(c, y, x);
        t.translucency.At(c, Y, X) = lm.translucency.At(c, y, x);
      }
      t.thickness.At(0, Y, X) = lm.thickness.At(0, y, x);
      t.mask.At(0, Y, X) = 1;
    }
  // Markers: opaque black squares near the corners.
  const int ms = std::max(4, int(std::lround(o.marker_mm / o.mm_per_pixel)));
  const int mx[4] = {3, W - 3 - ms, 3, W - 3 - ms}, my[4] = {3, 3, H - 3 - ms, H - 3 - ms};
  std::vector<uint8_t> marker(np, 0);
  for (int k = 0; k < 4; ++k)
    for (int y = my[k]; y < my[k] + ms; ++y)
      for (int x = mx[k]; x < mx[k] + ms; ++x) marker[int64_t(y) * W + x] = 1;
  // Sheet coordinates: u right, v up, in units of the half width, origin at the centre.
  auto uv = [&](int x, int y, double* u, double* v) {
    *u = (x + 0.5) / (W / 2.0) - 1, *v = (H / 2.0 - (y + 0.5)) / (W / 2.0);
  };
  auto finish = [&](float v) { return o.quantize ? Quantize(v) : std::clamp(v, 0.0f, 1.0f); };

  // Top-lit (or the minimal front-lit photo): I = E(x) ρ max(0, n·l); the sheet ρ = 1, n = z.
  const int nl = o.minimal ? 1 : 12;
  if (!o.minimal) {
    s.scan.top = LightStack(W, H, 3, nl);
  } else {
    s.scan.front = Image(W, H, 3);
  }
  for (int k = 0; k < nl; ++k) {
    // The shared rig's ring at 45°, or (two_rings) alternately at 30° and 60° elevation.
    const double el_deg = o.two_rings ? (k % 2 ? 30.0 : 60.0) : 45.0;
    const double az = (225.0 - 30.0 * k) * std::numbers::pi / 180,
                 el = el_deg * std::numbers::pi / 180;
    const Vec3 l =
        o.minimal ? Vec3(0, 0, 1)
                  : Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    // The lamp stands off the sheet toward its azimuth: its foot point is outside the frame.
    const double fu = o.minimal ? 0.2 : 1.6 * std::cos(az),
                 fv = o.minimal ? 0.1 : 1.6 * std::sin(az);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        double u, v;
        uv(x, y, &u, &v);
        const int64_t i = int64_t(y) * W + x;
        const double e = 0.9 * NearLight(u, v, fu, fv, 1.6) / NearLight(0, 0, fu, fv, 1.6) * 0.8;
        const Vec3 n(t.normal.Plane(0)[i], t.normal.Plane(1)[i], t.normal.Plane(2)[i]);
        const double cosl = std::max(0.0, Dot(n, l));
        for (int c = 0; c < 3; ++c) {
          const double rho = marker[i] ? 0.03 : t.albedo.Plane(c)[i];
          const float val = finish(float(e * rho * cosl));
          if (o.minimal) {
            s.scan.front.Plane(c)[i] = val;
          } else {
            s.scan.top.Plane(k, c)[int64_t(y) * s.scan.top.width() + x] = val;
          }
        }
      }
    if (!o.minimal) {
      LightSample ls;
      ls.direction = l;
      AnglesDegFromDirection(l, &ls.theta_deg, &ls.phi_deg);
      s.scan.top.lights()[k] = ls;
      char name[32];
      std::snprintf(name, sizeof name, "%d_TL.png", k + 1);
      s.scan.top.image_files.push_back(name);
    }
    if (progress) progress(k + 1, nl + o.back_images);
  }
  if (!o.minimal) s.scan.top.layout = "lp";
  // Back-lit: B_k(x) T(x), the back lamp behind the sheet at varying positions and exposures.
  for (int k = 0; k < o.back_images; ++k) {
    const double fu = 0.5 * std::cos(2.1 * k + 0.4), fv = 0.4 * std::sin(2.1 * k + 0.4);
    const double gain = 0.85 + 0.25 * k / std::max(1, o.back_images - 1);  // the last one clips
    Image img(W, H, 3);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        double u, v;
        uv(x, y, &u, &v);
        const int64_t i = int64_t(y) * W + x;
        const double b = gain * NearLight(u, v, fu, fv, 1.2) / NearLight(0, 0, fu, fv, 1.2);
        for (int c = 0; c < 3; ++c)
          img.Plane(c)[i] = finish(float(b * (marker[i] ? 0.0 : t.translucency.Plane(c)[i])));
      }
    s.scan.back.push_back(std::move(img));
    char name[32];
    std::snprintf(name, sizeof name, "%d_BL.png", k + 1);
    s.scan.back_files.push_back(name);
    if (progress) progress(nl + k + 1, nl + o.back_images);
  }
  // Truth translucency outside the leaf is the bare sheet's 1; keep 0 there for comparisons.
  for (int c = 0; c < 3; ++c)
    for (int64_t i = 0; i < np; ++i)
      if (t.mask.Plane(0)[i] < 0.5f) t.translucency.Plane(c)[i] = 0, t.albedo.Plane(c)[i] = 0;
  if (o.displacement) {
    // Registered displacement scans of both sides (mm): the upper surface's height field and the
    // lower one beneath it by the thickness.
    s.scan.upper_displacement = Image(W, H, 1), s.scan.lower_displacement = Image(W, H, 1);
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        const int X = s.leaf_x0 + x, Y = s.leaf_y0 + y;
        const float hmm = float(lm.height_map.At(0, y, x) * o.mm_per_pixel);
        s.scan.upper_displacement.At(0, Y, X) = hmm;
        s.scan.lower_displacement.At(0, Y, X) = hmm - t.thickness.At(0, Y, X);
      }
    s.scan.displacement_scale_mm = 1.0;
  }
  s.scan.source = "synthetic";
  s.scan.marker_size_mm = o.marker_mm;
  float dmax = 0;
  for (float d : t.thickness.data()) dmax = std::max(dmax, d);
  s.scan.max_thickness_mm = dmax;
  return s;
}

}  // namespace matfit::leaf
