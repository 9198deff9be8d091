#include <zip.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/image_io.h"
#include "core/pack/gltf.h"
#include "core/pack/pack.h"
#include "core/pack/shader_params.h"
#include "core/shading/evaluate.h"
#include "core/version.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string NowIso8601() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

// Relit view of the maps under one light (θ = 35°, φ = 45°: up and to the right), sRGB PNG.
Image Preview(const MaterialMaps& m, const std::vector<uint8_t>& status) {
  Image img(m.width, m.height, 3);
  const Vec3f l(DirectionFromAnglesDeg(35, 45)), v(0, 0, 1);
  for (int64_t p = 0; p < int64_t(m.width) * m.height; ++p)
    if (status[p] == 0)
      for (int c = 0; c < 3; ++c) img.Plane(c)[p] = EvaluateTexel(m, p, c, l, v);
  return img;
}

Image NormalColour(const Image& n) {
  Image out(n.width(), n.height(), 3);
  for (size_t i = 0; i < n.data().size(); ++i) out.data()[i] = n.data()[i] * 0.5f + 0.5f;
  return out;
}

}  // namespace

Status ZipFolder(const std::string& folder, const std::string& zip_path) {
  int err = 0;
  zip_t* z = zip_open(zip_path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  if (!z)
    return IoError("cannot create zip '" + zip_path + "' (libzip error " + std::to_string(err) +
                   ")");
  for (const auto& e : fs::recursive_directory_iterator(folder)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), folder).string();
    // Length -1: to the end of the file.
    zip_source_t* src = zip_source_file(z, e.path().c_str(), 0, -1);
    if (!src || zip_file_add(z, rel.c_str(), src, ZIP_FL_ENC_UTF_8) < 0) {
      if (src) zip_source_free(src);
      const std::string msg = zip_strerror(z);
      zip_discard(z);
      return IoError("adding '" + rel + "' to '" + zip_path + "' failed: " + msg);
    }
  }
  if (zip_close(z) != 0) {
    const std::string msg = zip_strerror(z);
    zip_discard(z);
    return IoError("writing '" + zip_path + "' failed: " + msg);
  }
  return Status::Ok();
}

double RoughnessFromBlinnPhongExponent(double e) { return std::pow(2.0 / (e + 2.0), 0.25); }

Status WritePack(const MaterialMaps& m, const std::vector<uint8_t>& status, const PackInfo& info,
                 const PackWriteOptions& options, const std::string& out) {
  std::string folder_out = out;
  if (options.zip) folder_out = out + ".folder";  // staging name; only the zip is kept
  AtomicDir dir(folder_out);
  std::error_code ec;
  if (options.zip && fs::exists(out, ec) && !options.overwrite)
    return InvalidArgument("output '" + out +
                           "' already exists; choose another --out or pass --force");
  MATFIT_RETURN_IF_ERROR(dir.Begin(true));
  const fs::path root(dir.temp_path());
  fs::create_directories(root / "maps", ec);
  if (ec) return IoError("cannot create '" + (root / "maps").string() + "': " + ec.message());

  json maps = json::array();
  auto put = [&](const char* name, const char* file, const Image& img, ImageWriteOptions wo,
                 const char* semantic) -> Status {
    if (img.empty()) return Status::Ok();
    MATFIT_RETURN_IF_ERROR(WriteImage((root / "maps" / file).string(), img, wo));
    const char* enc = wo.format == PixelFormat::kUint8    ? "png8"
                      : wo.format == PixelFormat::kUint16 ? "png16"
                                                          : "exr32";
    maps.push_back({{"name", name},
                    {"file", std::string("maps/") + file},
                    {"semantic", semantic},
                    {"encoding", enc},
                    {"color_space", wo.transfer == TransferFunction::kSrgb ? "sRGB" : "linear"},
                    {"channels", img.channels()}});
    return Status::Ok();
  };
  const ImageWriteOptions srgb8{PixelFormat::kUint8, TransferFunction::kSrgb};
  const ImageWriteOptions lin8{PixelFormat::kUint8, TransferFunction::kLinear};
  const ImageWriteOptions lin16{PixelFormat::kUint16, TransferFunction::kLinear};
  const ImageWriteOptions exr{PixelFormat::kFloat, TransferFunction::kLinear};
  const bool has_normal = m.model != ShadingModel::kMean && m.model != ShadingModel::kPtm;
  const bool heinrich = m.model == ShadingModel::kHeinrich;
  MATFIT_RETURN_IF_ERROR(
      put("albedo", "albedo.png", m.albedo, srgb8,
          heinrich ? "mean texture t (seed diffuse texture)" : "diffuse albedo"));
  MATFIT_RETURN_IF_ERROR(
      put("albedo_exact", "albedo.exr", m.albedo, exr, "the same, linear float"));
  if (has_normal) {
    MATFIT_RETURN_IF_ERROR(put("normal", "normal.png", NormalColour(m.normal), lin16,
                               "tangent-space normal, OpenGL +Y, rgb = n*0.5+0.5"));
    MATFIT_RETURN_IF_ERROR(
        put("normal_exact", "normal.exr", m.normal, exr, "unit normal xyz (float)"));
  }
  if (heinrich) {
    MATFIT_RETURN_IF_ERROR(put("ambient", "ambient.exr", m.ambient, exr, "ambient factor a_c"));
    MATFIT_RETURN_IF_ERROR(put("normal_scale", "normal_scale.exr", m.normal_scale, exr,
                               "|n| of the unnormalised fitted normal"));
    MATFIT_RETURN_IF_ERROR(put("specular_exact", "specular.exr", m.specular_color, exr,
                               "L_spec residual of sample #1 (may be negative)"));
    MATFIT_RETURN_IF_ERROR(put("specular", "specular.png", m.specular_color, lin8,
                               "L_spec clamped to [0,1] (glTF specular colour)"));
  }
  const bool ct = m.model == ShadingModel::kCookTorrance, laf = m.model == ShadingModel::kLafortune;
  const bool lobe = m.model == ShadingModel::kBlinnPhong || ct || laf;
  if (lobe) {
    MATFIT_RETURN_IF_ERROR(put("specular", "specular.exr", m.specular, exr,
                               ct    ? "Cook-Torrance F0"
                               : laf ? "Lafortune lobe amplitudes rho_s,j"
                                     : "Blinn-Phong k_s"));
    MATFIT_RETURN_IF_ERROR(put("roughness", "roughness.exr", m.roughness, exr,
                               "GGX perceptual roughness r (alpha = r^2)"));
    MATFIT_RETURN_IF_ERROR(
        put("exponent", "exponent.exr", m.exponent, exr, "Blinn-Phong exponent e"));
    MATFIT_RETURN_IF_ERROR(put("lobe_shape", "lobe_shape.exr", m.lobe_shape, exr,
                               "Lafortune lobe j: C_xy (2j), exponent (2j+1)"));
    // glTF metallic-roughness texture: G = roughness (from the exponent of Blinn-Phong or of the
    // first Lafortune lobe), B = metallic = 0.
    Image mr(m.width, m.height, 3);
    for (int64_t p = 0; p < int64_t(m.width) * m.height; ++p) {
      mr.Plane(0)[p] = 1.0f;
      const double e = laf ? m.lobe_shape.Plane(1)[p] : ct ? 0.0 : m.exponent.Plane(0)[p];
      mr.Plane(1)[p] = float(ct ? m.roughness.Plane(0)[p] : RoughnessFromBlinnPhongExponent(e));
    }
    MATFIT_RETURN_IF_ERROR(put("metallic_roughness", "metallic_roughness.png", mr, lin8,
                               "glTF: G = roughness, B = metallic (0)"));
  }
  MATFIT_RETURN_IF_ERROR(put("coefficients", "coefficients.exr", m.coefficients, exr,
                             "relighting coefficients, channel c*k + j"));
  Image status_img(m.width, m.height, 1);
  for (size_t p = 0; p < status.size(); ++p) status_img.data()[p] = status[p] / 255.0f;
  MATFIT_RETURN_IF_ERROR(
      put("status", "status.png", status_img, lin8, "per-texel fit status code (0 = ok)"));
  MATFIT_RETURN_IF_ERROR(put("mask", "mask.png", m.mask, lin8, "1 = sample"));
  // Two-sided leaves (METHODS.md §5): render/ reads these; issue #5 fills them from scans.
  MATFIT_RETURN_IF_ERROR(put("thickness", "thickness.exr", m.thickness, exr, "leaf thickness, mm"));
  MATFIT_RETURN_IF_ERROR(put("translucency", "translucency.exr", m.translucency, exr,
                             "leaf translucency rho_t (back-lit transmission)"));
  MATFIT_RETURN_IF_ERROR(
      put("albedo_back", "albedo_back.exr", m.albedo_back, exr, "leaf lower-side diffuse albedo"));
  MATFIT_RETURN_IF_ERROR(put("hl2", "hl2.exr", m.hl2, exr,
                             "leaf HL2 translucency coefficients h1..h3 (light from behind)"));
  for (const PackExtraMap& e : info.extra_maps) {
    const bool png = fs::path(e.file).extension() == ".png";
    MATFIT_RETURN_IF_ERROR(
        put(e.name.c_str(), e.file.c_str(), e.image, png ? lin8 : exr, e.semantic.c_str()));
  }
  // Leaves in glTF terms (KHR_materials_diffuse_transmission): of the light not reflected
  // specularly, a fraction t = lum(ρ_t) / (lum(ρ_d) + lum(ρ_t)) is transmitted with colour
  // ρ_t / t and the rest reflected with colour ρ_d / (1 − t), so that a glTF renderer
  // reproduces the measured reflectance ρ_d and transmittance ρ_t. Alpha = mask.
  const bool leaf = !m.translucency.empty();
  if (leaf) {
    const int64_t np = int64_t(m.width) * m.height;
    Image base(m.width, m.height, 4), trans(m.width, m.height, 4);
    auto lum = [](const Image& im, int64_t p) {
      return 0.2126 * im.Plane(0)[p] + 0.7152 * im.Plane(1)[p] + 0.0722 * im.Plane(2)[p];
    };
    for (int64_t p = 0; p < np; ++p) {
      const double ld = lum(m.albedo, p), lt = lum(m.translucency, p);
      const double tf = ld + lt > 1e-6 ? lt / (ld + lt) : 0.0;
      for (int c = 0; c < 3; ++c) {
        base.Plane(c)[p] = float(std::min(1.0, m.albedo.Plane(c)[p] / std::max(1e-6, 1 - tf)));
        trans.Plane(c)[p] = float(std::min(1.0, m.translucency.Plane(c)[p] / std::max(1e-6, tf)));
      }
      base.Plane(3)[p] = m.mask.empty() ? 1.0f : m.mask.Plane(0)[p];
      trans.Plane(3)[p] = float(tf);
    }
    MATFIT_RETURN_IF_ERROR(put("gltf_base_color", "gltf_base_color.png", base, srgb8,
                               "glTF base colour rho_d/(1-t), alpha = mask"));
    MATFIT_RETURN_IF_ERROR(put("gltf_diffuse_transmission", "gltf_diffuse_transmission.png", trans,
                               srgb8, "glTF diffuse transmission: rgb = rho_t/t, a = t (linear)"));
  }
  MATFIT_RETURN_IF_ERROR(WriteImage((root / "preview.png").string(), Preview(m, status), srgb8));
  json previews = json::array({"preview.png"});
  for (const auto& [name, img] : info.previews) {
    MATFIT_RETURN_IF_ERROR(WriteImage((root / name).string(), img, srgb8));
    previews.push_back(name);
  }

  // The shaders' parameter planes for the web viewer (core/pack/shader_params.h).
  json viewer;
  {
    auto sp = PackShaderParams(m);
    if (!sp.ok()) return sp.status();
    fs::create_directories(root / "viewer", ec);
    if (ec) return IoError("cannot create '" + (root / "viewer").string() + "': " + ec.message());
    static_assert(std::endian::native == std::endian::little, "params.bin is little-endian");
    MATFIT_RETURN_IF_ERROR(
        WriteFileAtomic((root / "viewer" / "params.bin").string(),
                        std::string(reinterpret_cast<const char*>(sp->texels.data()),
                                    sp->texels.size() * sizeof(float))));
    viewer = {{"params", "viewer/params.bin"},
              {"encoding", "float32le rgba layers"},
              {"width", sp->width},
              {"height", sp->height},
              {"layers", sp->layers},
              {"model_index", sp->model},
              {"terms", sp->terms},
              {"coef_channels", sp->coef_channels},
              {"heinrich_specular", sp->heinrich_specular},
              {"flat_normal", sp->flat_normal},
              {"leaf_base", sp->leaf_base},
              {"leaf_hl2", sp->leaf_hl2}};
  }

  // glTF quad.
  GltfMaterialDesc g;
  g.name = info.method;
  g.base_color_uri = leaf ? "maps/gltf_base_color.png" : "maps/albedo.png";
  if (leaf) {
    g.diffuse_transmission_uri = "maps/gltf_diffuse_transmission.png";
    g.double_sided = true, g.alpha_mask = !m.mask.empty();
  }
  if (has_normal) g.normal_uri = "maps/normal.png";
  g.specular_factor = 0.0;
  if (heinrich && !m.specular_color.empty()) {
    g.specular_color_uri = "maps/specular.png";
    g.specular_factor = 1.0;
    auto e = info.model_parameters.find("exponent");
    if (e != info.model_parameters.end()) g.roughness = RoughnessFromBlinnPhongExponent(e->second);
  }
  if (lobe) {
    g.metallic_roughness_uri = "maps/metallic_roughness.png";
    g.specular_factor = 1.0;
    if (m.model == ShadingModel::kCookTorrance) {
      // Median F0 → index of refraction: η = (1 + √F0) / (1 − √F0).
      std::vector<float> f0;
      for (size_t p = 0; p < status.size(); ++p)
        if (status[p] == 0) f0.push_back(m.specular.data()[p]);
      if (!f0.empty()) {
        std::nth_element(f0.begin(), f0.begin() + f0.size() / 2, f0.end());
        const double r0 = std::sqrt(std::clamp(double(f0[f0.size() / 2]), 0.0, 0.81));
        g.ior = (1 + r0) / (1 - r0);
      }
    }
  }
  const double mm = info.mm_per_texel > 0 ? info.mm_per_texel : 0.5;  // unknown: 0.5 mm/texel
  g.width_m = m.width * mm / 1000, g.height_m = m.height * mm / 1000;
  std::vector<uint8_t> bin;
  const std::string gltf = MakeQuadGltf(g, "quad.bin", &bin);
  MATFIT_RETURN_IF_ERROR(
      WriteFileAtomic((root / "quad.bin").string(), std::string(bin.begin(), bin.end())));
  MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "material.gltf").string(), gltf));

  json params = json::object();
  for (const auto& [k, v] : info.model_parameters) params[k] = v;
  if (m.basis_terms > 0) params["basis_terms"] = m.basis_terms;
  if (heinrich) params["specular_flat_normal"] = m.specular_flat_normal ? 1 : 0;
  json report_summary = json::object();
  if (!info.report_json.empty()) {
    const json r = json::parse(info.report_json, nullptr, false);
    for (const char* k : {"deviation_percent", "rmse", "psnr_db", "flagged_texels", "fit_seconds"})
      if (r.is_object() && r.contains(k)) report_summary[k] = r[k];
  }
  json material = {
      {"schema", "matfit.material/1"},
      {"model",
       {{"name", ShadingModelName(m.model)}, {"method", info.method}, {"parameters", params}}},
      {"size",
       {{"width", m.width},
        {"height", m.height},
        {"mm_per_texel", info.mm_per_texel > 0 ? json(info.mm_per_texel) : json()}}},
      {"maps", maps},
      {"conventions",
       {{"tangent_frame", "x = image right, y = image up, z = out of the surface"},
        {"normal_map", "OpenGL (+Y up), rgb = n*0.5+0.5, 16-bit PNG"},
        {"reflectance", "pixel = intensity * R, R = pi * f_r * max(0, n.l)"}}},
      {"gltf", "material.gltf"},
      {"previews", previews},
      {"viewer", viewer},
      {"report", "report.json"},
      {"report_summary", report_summary},
      {"warnings", info.warnings},
      {"provenance",
       {{"input", info.source},
        {"method", info.method},
        {"version", std::string("matfit ") + kMatfitVersion},
        {"time", NowIso8601()}}},
  };
  MATFIT_RETURN_IF_ERROR(WriteFileAtomic(
      (root / "material.json").string(),
      material.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n"));
  const std::string report = info.final_report_json ? info.final_report_json() : info.report_json;
  if (!report.empty())
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "report.json").string(), report));

  if (!options.zip) {
    if (fs::exists(out, ec) && !options.overwrite)
      return InvalidArgument("output '" + out +
                             "' already exists; choose another --out or pass --force");
    return dir.Commit();
  }
  AtomicFile zip_file(out);
  MATFIT_RETURN_IF_ERROR(ZipFolder(root.string(), zip_file.temp_path()));
  return zip_file.Commit();  // the staging folder is removed by ~AtomicDir
}

}  // namespace matfit
