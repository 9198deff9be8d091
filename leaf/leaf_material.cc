#include "leaf/leaf_material.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "core/model/model.h"
#include "core/shading/shading.h"
#include "core/warnings.h"
#include "fit/method.h"
#include "leaf/horizon.h"
#include "leaf/integrate.h"

namespace matfit::leaf {

bool LeafMaterialOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!translucency.Check(why)) return false;
  auto num = [](double v) { return std::to_string(v); };
  if (!(default_max_thickness_mm > 0 && default_max_thickness_mm < 10))
    return fail("default maximum thickness must be in (0, 10) mm, got " +
                num(default_max_thickness_mm));
  if (!(sheet_albedo > 0 && sheet_albedo <= 1))
    return fail("sheet_albedo must be in (0, 1], got " + num(sheet_albedo));
  if (!(default_f0 >= 0 && default_f0 < 1))
    return fail("default F0 must be in [0, 1), got " + num(default_f0));
  if (!(default_roughness > 0 && default_roughness <= 1))
    return fail("default roughness must be in (0, 1], got " + num(default_roughness));
  if (margin_px < 0 || margin_px > 256)
    return fail("margin must be in 0..256 pixels, got " + std::to_string(margin_px));
  return true;
}

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Image CropImage(const Image& src, int x0, int y0, int w, int h) {
  Image out(w, h, src.channels());
  for (int c = 0; c < src.channels(); ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) out.At(c, y, x) = src.At(c, y0 + y, x0 + x);
  return out;
}

double Percentile(std::vector<float> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, size_t(q * (v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

}  // namespace

StatusOr<LeafMaterial> MakeLeafMaterial(const LeafScan& scan, const SheetAnalysis& sheet,
                                        const Component& leaf, double mm,
                                        const LeafMaterialOptions& o, const ProgressFn& progress) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument("leaf material options: " + why);
  if (!(mm >= 1e-3 && mm <= 100))
    return InvalidArgument("mm_per_pixel must be in [0.001, 100], got " + std::to_string(mm));
  const Status cancelled(StatusCode::kCancelled, "cancelled");
  auto tick = [&](int64_t done) { return !progress || progress(done, kLeafMaterialSteps); };
  const auto t_maps = std::chrono::steady_clock::now();
  LeafMaterial L;
  L.component = leaf;
  L.mm_per_texel = mm;
  const int x0 = std::max(0, leaf.x0 - o.margin_px), y0 = std::max(0, leaf.y0 - o.margin_px);
  const int x1 = std::min(sheet.width - 1, leaf.x1 + o.margin_px);
  const int y1 = std::min(sheet.height - 1, leaf.y1 + o.margin_px);
  const int w = x1 - x0 + 1, h = y1 - y0 + 1;
  const int64_t n = int64_t(w) * h;
  L.crop_x = x0, L.crop_y = y0;
  std::vector<uint8_t> mask(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      mask[int64_t(y) * w + x] =
          sheet.segmentation.labels[size_t(y0 + y) * sheet.width + x0 + x] == leaf.label;
  MaterialMaps& m = L.maps;
  m.width = w, m.height = h, m.model = ModelId("cook-torrance");
  m.mask = Image(w, h, 1);
  for (int64_t i = 0; i < n; ++i) m.mask.Plane(0)[i] = mask[i];
  L.status.assign(n, 0);
  for (int64_t i = 0; i < n; ++i)
    if (!mask[i]) L.status[i] = fit::kTexelMasked;

  // Upper side: robust photometric stereo on the flat-fielded top-lit images.
  m.normal = Image(w, h, 3), m.albedo = Image(w, h, 3);
  for (int64_t i = 0; i < n; ++i) m.normal.Plane(2)[i] = 1;
  const bool have_top = sheet.top.num_images() > 0;
  LightStack crop;
  if (have_top) {
    const LightStack& s = sheet.top;
    crop = LightStack(w, h, s.channels(), s.num_images());
    for (int k = 0; k < s.num_images(); ++k)
      for (int c = 0; c < s.channels(); ++c)
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x)
            crop.Plane(k, c)[int64_t(y) * w + x] = s.At(k, c, y0 + y, x0 + x);
    crop.lights() = s.lights();
    crop.mask = mask;
    crop.mm_per_texel = mm;
    crop.saturated_pixels = s.saturated_pixels;  // clipped samples read 1 (leaf/sheet.h)
    crop.layout = s.layout, crop.source = s.source, crop.image_files = s.image_files;
    auto ps = fit::MakeMethod("lambert-robust")->Fit(crop, fit::FitOptions{});
    if (!ps.ok()) return ps.status();
    m.normal = ps->maps.normal;
    for (int c = 0; c < 3; ++c)
      for (int64_t i = 0; i < n; ++i)
        m.albedo.Plane(c)[i] = float(o.sheet_albedo) * ps->maps.albedo.Plane(std::min(
                                                           c, ps->maps.albedo.channels() - 1))[i];
    for (int64_t i = 0; i < n; ++i)
      if (mask[i] && ps->status[i] != fit::kTexelOk) {
        L.status[i] = ps->status[i];  // flagged: keep the flat normal
        m.normal.Plane(0)[i] = m.normal.Plane(1)[i] = 0, m.normal.Plane(2)[i] = 1;
      }
  } else if (!sheet.front.empty()) {
    const Image f = CropImage(sheet.front, x0, y0, w, h);
    for (int c = 0; c < 3; ++c)
      for (int64_t i = 0; i < n; ++i)
        m.albedo.Plane(c)[i] = float(o.sheet_albedo) * f.Plane(std::min(c, f.channels() - 1))[i];
    L.warnings.push_back(Warning(WarningCode::kLeafNoTopLight,
                                 "no top-lit images: the upper normal is flat (0, 0, 1)"));
  }
  if (!scan.upper_normal.empty()) {  // a scanned normal map wins over photometric stereo
    const Image nm = CropImage(scan.upper_normal, x0, y0, w, h);
    for (int64_t i = 0; i < n; ++i) {
      const Vec3 v = Normalize(Vec3(2.0 * nm.Plane(0)[i] - 1, 2.0 * nm.Plane(1)[i] - 1,
                                    2.0 * nm.Plane(std::min(2, nm.channels() - 1))[i] - 1));
      m.normal.Plane(0)[i] = float(v.x), m.normal.Plane(1)[i] = float(v.y);
      m.normal.Plane(2)[i] = float(v.z);
    }
  }
  if (!scan.upper_albedo.empty()) m.albedo = CropImage(scan.upper_albedo, x0, y0, w, h);
  if (!scan.lower_albedo.empty()) m.albedo_back = CropImage(scan.lower_albedo, x0, y0, w, h);
  for (int64_t i = 0; i < n; ++i) {
    if (mask[i]) continue;
    for (int c = 0; c < 3; ++c) m.albedo.Plane(c)[i] = 0;
    m.normal.Plane(0)[i] = m.normal.Plane(1)[i] = 0, m.normal.Plane(2)[i] = 1;
  }

  if (!tick(1)) return cancelled;
  // Specular: a Cook–Torrance fit needs lights at several elevations (with one ring of lights
  // and an overhead camera every light has the same half-vector elevation on a flat texel, so
  // F0 and roughness cannot be told apart); otherwise the leaf default.
  m.specular = Image(w, h, 1, float(o.default_f0));
  m.roughness = Image(w, h, 1, float(o.default_roughness));
  if (have_top) {
    double tmin = 90, tmax = 0;
    for (const auto& l : crop.lights()) {
      const double t = std::acos(std::clamp(l.direction.z, -1.0, 1.0)) * 180 / std::numbers::pi;
      tmin = std::min(tmin, t), tmax = std::max(tmax, t);
    }
    if (tmax - tmin >= 10 && crop.num_images() >= 6) {
      auto ct = fit::MakeMethod("cook-torrance")->Fit(crop, fit::FitOptions{});
      if (ct.ok()) {
        m.specular = ct->maps.specular, m.roughness = ct->maps.roughness;
        L.specular_fitted = true;
      } else {
        L.warnings.push_back(Warning(WarningCode::kLeafSpecularFailed,
                                     "Cook-Torrance fit failed (" + ct.status().message() +
                                         "): leaf default specular used"));
      }
    } else {
      L.warnings.push_back(
          Warning(WarningCode::kLeafNarrowLights,
                  "the top-lit lights span " + std::to_string(int(tmax - tmin)) +
                      "° of elevation: too little to fit a specular lobe; leaf default "
                      "F0 and roughness used"));
    }
  }

  // Translucency ρ_t: the fused back-lit transmission.
  m.translucency = CropImage(sheet.transmission, x0, y0, w, h);
  for (int c = 0; c < 3; ++c)
    for (int64_t i = 0; i < n; ++i) {
      float& v = m.translucency.Plane(c)[i];
      v = mask[i] ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
    }
  const Image lum = Luminance(m.translucency);

  // Thickness: from the two displacement maps, else Beer–Lambert on the transmission
  // (METHODS.md §6): I = I₀ e^{−α s} → s ∝ −ln(I/I₀), scaled to the maximum thickness.
  m.thickness = Image(w, h, 1);
  std::vector<float> tau(n, 0.0f), tau_in;
  for (int64_t i = 0; i < n; ++i)
    if (mask[i])
      tau[i] = float(-std::log(std::clamp(lum.Plane(0)[i], 1e-3f, 1.0f))), tau_in.push_back(tau[i]);
  const double tau99 = std::max(1e-6, Percentile(tau_in, 0.99));
  const double dmax =
      scan.max_thickness_mm > 0 ? scan.max_thickness_mm : o.default_max_thickness_mm;
  if (!scan.upper_displacement.empty() && !scan.lower_displacement.empty()) {
    L.thickness_estimated = false;
    const Image up = CropImage(scan.upper_displacement, x0, y0, w, h);
    const Image lo = CropImage(scan.lower_displacement, x0, y0, w, h);
    std::vector<float> d_in;
    for (int64_t i = 0; i < n; ++i)
      if (mask[i]) {
        m.thickness.Plane(0)[i] =
            float(std::max(0.0, (up.Plane(0)[i] - lo.Plane(0)[i]) * scan.displacement_scale_mm));
        d_in.push_back(m.thickness.Plane(0)[i]);
      }
    const double d99 = Percentile(d_in, 0.99);
    if (scan.max_thickness_mm > 0 && d99 > 0)
      for (float& v : m.thickness.data()) v = float(v * scan.max_thickness_mm / d99);
  } else {
    for (int64_t i = 0; i < n; ++i)
      if (mask[i]) m.thickness.Plane(0)[i] = float(std::min(1.5 * dmax, dmax * tau[i] / tau99));
    L.warnings.push_back(Warning(
        WarningCode::kThicknessEstimated,
        std::string("thickness is an estimate: Beer-Lambert from the transmission, scaled to ") +
            (scan.max_thickness_mm > 0 ? "the measured" : "the default") + " maximum " +
            std::to_string(dmax) + " mm"));
  }

  // The 2005 derived maps.
  {
    float lmax = 1e-6f;
    for (int64_t i = 0; i < n; ++i)
      if (mask[i]) lmax = std::max(lmax, lum.Plane(0)[i]);
    L.thickness_variation = Image(w, h, 1), L.absorption = Image(w, h, 1), L.bump = Image(w, h, 1);
    const Image alb = Luminance(m.albedo);
    cv::Mat a(h, w, CV_32F), blur;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) a.at<float>(y, x) = alb.At(0, y, x);
    cv::GaussianBlur(a, blur, cv::Size(0, 0), 3.0);
    for (int64_t i = 0; i < n; ++i) {
      if (!mask[i]) continue;
      L.thickness_variation.Plane(0)[i] = 1 - lum.Plane(0)[i] / lmax;
      L.absorption.Plane(0)[i] = float(std::clamp(tau[i] / tau99, 0.0, 1.0));
      const int y = int(i / w), x = int(i % w);
      const float hp = a.at<float>(y, x) - blur.at<float>(y, x);
      const float mean = std::max(1e-4f, blur.at<float>(y, x));
      L.bump.Plane(0)[i] = std::clamp(0.5f + 0.5f * hp / mean, 0.0f, 1.0f);
    }
  }
  L.seconds_maps = Seconds(t_maps);
  if (!tick(2)) return cancelled;

  // Translucency precompute for light from behind, in the lower side's frame
  // (x' = x, y' = −y, z' = −z; METHODS.md §5): n' = (−n_x, n_y, n_z), heights negated.
  const auto t_tr = std::chrono::steady_clock::now();
  // Height of the lower surface along z' (mm): −lower displacement when scanned, else −upper
  // displacement, else − the integrated upper normals (a thin sheet). Off the leaf the height is
  // the leaf's lowest, so the sheet around it never shadows the rim.
  Image lower_height(w, h, 1);
  if (!scan.lower_displacement.empty() || !scan.upper_displacement.empty()) {
    const Image d = CropImage(
        scan.lower_displacement.empty() ? scan.upper_displacement : scan.lower_displacement, x0, y0,
        w, h);
    for (int64_t i = 0; i < n; ++i)
      lower_height.Plane(0)[i] = float(-d.Plane(0)[i] * scan.displacement_scale_mm);
  } else {
    const Image ht = HeightFromNormals(m.normal, mask);
    for (int64_t i = 0; i < n; ++i) lower_height.Plane(0)[i] = float(-ht.Plane(0)[i] * mm);
  }
  float lowest = 1e30f;
  for (int64_t i = 0; i < n; ++i)
    if (mask[i]) lowest = std::min(lowest, lower_height.Plane(0)[i]);
  for (int64_t i = 0; i < n; ++i)
    if (!mask[i]) lower_height.Plane(0)[i] = lowest;
  Image lower_normal(w, h, 3);
  const Image scanned_lower =
      scan.lower_normal.empty() ? Image() : CropImage(scan.lower_normal, x0, y0, w, h);
  for (int64_t i = 0; i < n; ++i) {
    Vec3 v(-m.normal.Plane(0)[i], m.normal.Plane(1)[i], m.normal.Plane(2)[i]);
    if (!scanned_lower.empty() && mask[i])  // a scan of the lower side wins
      v = Normalize(
          Vec3(2.0 * scanned_lower.Plane(0)[i] - 1, 2.0 * scanned_lower.Plane(1)[i] - 1,
               2.0 * scanned_lower.Plane(std::min(2, scanned_lower.channels() - 1))[i] - 1));
    lower_normal.Plane(0)[i] = float(v.x), lower_normal.Plane(1)[i] = float(v.y);
    lower_normal.Plane(2)[i] = float(v.z);
  }
  const Image horizon = HorizonMap(lower_height, mm, +1, HorizonOptions{});
  TransportInput in;
  in.mm_per_texel = mm, in.rho = &lum, in.thickness = &m.thickness, in.normal = &lower_normal;
  in.horizon = &horizon, in.mask = &mask;
  auto tr = o.reference_precompute ? PrecomputeTranslucencyReference(in, o.translucency)
                                   : PrecomputeTranslucencyFast(in, o.translucency);
  if (!tr.ok()) return tr.status();
  L.translucency = std::move(*tr);
  m.hl2 = L.translucency.hl2;
  for (int64_t i = 0; i < n; ++i)
    if (mask[i] && L.translucency.thin[i] && L.status[i] == 0) L.status[i] = kLeafTexelThin;
  for (const auto& wmsg : L.translucency.warnings) L.warnings.push_back(wmsg);
  L.seconds_translucency = Seconds(t_tr);
  if (!tick(3)) return cancelled;
  if (o.report_hl2_error) {
    const auto t_e = std::chrono::steady_clock::now();
    auto e = Hl2ReconstructionErrors(
        in, o.translucency, L.translucency,
        {std::numbers::pi / 2, std::numbers::pi / 4, std::numbers::pi / 8}, o.hl2_error_texels);
    if (!e.ok()) return e.status();
    for (int k = 0; k < 3; ++k) L.hl2_error[k] = (*e)[k];
    L.seconds_hl2_error = Seconds(t_e);
  }
  if (!tick(4)) return cancelled;
  return L;
}

}  // namespace matfit::leaf
