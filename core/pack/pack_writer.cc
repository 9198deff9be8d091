#include <zip.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/atomic_file.h"
#include "core/height_from_normals.h"
#include "core/image_io.h"
#include "core/model/model.h"
#include "core/output_marker.h"
#include "core/pack/gltf.h"
#include "core/pack/gltf_bake.h"
#include "core/pack/pack.h"
#include "core/pack/pack_exports.h"
#include "core/pack/shader_params.h"
#include "core/parallel.h"
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
constexpr uint8_t kStatusMasked = 1;  // fit/fit_types.h kTexelMasked (core does not see fit/)

Image Preview(const MaterialMaps& m, const std::vector<uint8_t>& status) {
  Image img(m.width, m.height, 3);
  const BatchEvaluator eval(m, {Vec3f(DirectionFromAnglesDeg(35, 45))}, Vec3f(0, 0, 1));
  const int64_t T = int64_t(m.width) * m.height;
  ParallelFor(0, (T + kEvalRun - 1) / kEvalRun, [&](int64_t r0, int64_t r1) {
    float out[3 * kEvalRun];
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t p0 = r * kEvalRun;
      const int n = int(std::min<int64_t>(kEvalRun, T - p0));
      eval.Evaluate(0, p0, n, 3, out);
      for (int t = 0; t < n; ++t) {
        const int64_t p = p0 + t;
        const uint8_t st = status[size_t(p)];
        if (st == kStatusMasked) continue;  // outside the object: black
        // Flagged texels show the maps' own estimate (no holes); a texel with no estimate at
        // all (no normal, non-finite value) is marked magenta, never silently black.
        bool estimate = true;
        if (!m.normal.empty()) {
          const float nx = m.normal.Plane(0)[p], ny = m.normal.Plane(1)[p],
                      nz = m.normal.Plane(2)[p];
          estimate = nx * nx + ny * ny + nz * nz > 0.25f;
        }
        for (int c = 0; c < 3; ++c) estimate = estimate && std::isfinite(out[c * n + t]);
        for (int c = 0; c < 3; ++c)
          img.Plane(c)[p] = estimate ? out[c * n + t] : (c == 1 ? 0.0f : 1.0f);
      }
    }
  });
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

// The height map integrated from the normals (core/height_from_normals.h) over the texels with a
// fitted normal: inside the mask, status ok (0), unverifiable (7) or suspect (8) — the codes of
// fit/fit_types.h whose normal was fitted. height.exr in texel units (mean 0), height.png 16-bit
// from its minimum (0) to its maximum (65535), the range in material.json.
constexpr int64_t kMaxHeightTexels = int64_t(4096) * 4096;
// Up to this size the height is made beside the other files (its solve's memory on top of
// theirs); above, alone before them, so that the peak stays the larger of the two, not the sum.
constexpr int64_t kHeightBesideFilesTexels = int64_t(2048) * 2048;

// Integrates the height and writes height.exr and height.png under `maps_dir`; *written says
// whether IntegrateNormals made a height (always, unless the normal map has fewer than 3 planes;
// without a fitted texel the height is flat, range [0, 0]), *range its [min, max].
Status WriteHeightMaps(const MaterialMaps& m, const std::vector<uint8_t>& status,
                       const fs::path& maps_dir, const ImageWriteOptions& exr,
                       const ImageWriteOptions& lin16, bool* written, double range[2]) {
  const int64_t n = int64_t(m.width) * m.height;
  std::vector<uint8_t> trusted(size_t(n), 1);
  for (int64_t p = 0; p < n; ++p) {
    const uint8_t st = size_t(p) < status.size() ? status[p] : 0;
    const bool fitted = st == 0 || st == 7 || st == 8;
    trusted[p] = fitted && (m.mask.empty() || m.mask.Plane(0)[p] > 0.5f);
  }
  HeightResult h = IntegrateNormals(m.normal, trusted);
  *written = !h.height.empty();
  if (!*written) return Status::Ok();
  range[0] = h.min, range[1] = h.max;
  MATFIT_RETURN_IF_ERROR(WriteImage((maps_dir / "height.exr").string(), h.height, exr));
  const double span = h.max - h.min;
  float* v = h.height.Plane(0).data();  // rescaled in place: the EXR is written
  for (int64_t p = 0; p < n; ++p) v[p] = span > 0 ? float((v[p] - h.min) / span) : 0.5f;
  return WriteImage((maps_dir / "height.png").string(), h.height, lin16);
}

double RoughnessFromBlinnPhongExponent(double e) { return std::pow(2.0 / (e + 2.0), 0.25); }

Status WritePack(const MaterialMaps& m, const std::vector<uint8_t>& status, const PackInfo& info,
                 const PackWriteOptions& options, const std::string& out) {
  std::string folder_out = out;
  if (options.zip) folder_out = out + ".folder";  // staging name; only the zip is kept
  AtomicDir dir(folder_out, "pack");
  std::error_code ec;
  if (options.zip) MATFIT_RETURN_IF_ERROR(CheckOutput(out, options.overwrite));
  MATFIT_RETURN_IF_ERROR(dir.Begin(options.zip || options.overwrite));
  const fs::path root(dir.temp_path());
  fs::create_directories(root / "maps", ec);
  if (ec) return IoError("cannot create '" + (root / "maps").string() + "': " + ec.message());

  // Image files are encoded in parallel at the end (PNG and EXR compression dominate the
  // write); material.json lists them in the order they are put here.
  std::vector<std::function<Status()>> tasks;
  std::deque<Image> owned;  // images made for the pack (stable addresses until written)
  auto keep = [&](Image img) -> const Image& { return owned.emplace_back(std::move(img)); };
  json maps = json::array();
  // Adds material.json's entry for a map file; returns its index in `maps`.
  auto describe = [&](const char* name, const char* file, int channels, ImageWriteOptions wo,
                      const char* semantic) -> size_t {
    const char* enc = wo.format == PixelFormat::kUint8    ? "png8"
                      : wo.format == PixelFormat::kUint16 ? "png16"
                                                          : "exr32";
    maps.push_back({{"name", name},
                    {"file", std::string("maps/") + file},
                    {"semantic", semantic},
                    {"encoding", enc},
                    {"color_space", wo.transfer == TransferFunction::kSrgb ? "sRGB" : "linear"},
                    {"channels", channels}});
    return maps.size() - 1;
  };
  auto put = [&](const char* name, const char* file, const Image& img, ImageWriteOptions wo,
                 const char* semantic) -> Status {
    if (img.empty()) return Status::Ok();
    tasks.push_back(
        [path = (root / "maps" / file).string(), &img, wo] { return WriteImage(path, img, wo); });
    describe(name, file, img.channels(), wo, semantic);
    return Status::Ok();
  };
  const bool compact = options.compact;
  const ImageWriteOptions srgb8{PixelFormat::kUint8, TransferFunction::kSrgb, compact};
  const ImageWriteOptions lin8{PixelFormat::kUint8, TransferFunction::kLinear, compact};
  const ImageWriteOptions lin16{PixelFormat::kUint16, TransferFunction::kLinear, compact};
  const ImageWriteOptions exr{PixelFormat::kFloat, TransferFunction::kLinear, compact};
  const ModelDescriptor& model = Model(m.model);
  const bool has_normal = model.writes_normal_map();
  std::function<Status()> height_task;  // set when the pack has a height map
  std::optional<size_t> height_entry;   // height_exact's entry in `maps`; height's is the next
  bool height_written = false;
  double height_range[2] = {0, 0};
  // Progress in thousandths: the glTF bake (most of a relighting basis's write), the files,
  // the view packs; the rest (exports, glTF, material.json) is short.
  // Reported from worker threads: one at a time, and never backwards (two tasks may finish
  // in one order and report in the other).
  std::mutex progress_mutex;
  int64_t reported = 0;
  auto progress = [&](int64_t thousandths) {
    if (!options.progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    if (thousandths <= reported) return;
    reported = thousandths;
    (void)options.progress(thousandths, 1000);
  };
  const int64_t files_end = info.views.empty() ? 950 : 400;
  const int64_t bake_end = model.gltf_baked() ? files_end * 7 / 10 : 0;
  MATFIT_RETURN_IF_ERROR(put("albedo", "albedo.png", m.albedo, srgb8, model.albedo_semantic()));
  MATFIT_RETURN_IF_ERROR(
      put("albedo_exact", "albedo.exr", m.albedo, exr, "the same, linear float"));
  if (has_normal) {
    MATFIT_RETURN_IF_ERROR(put("normal", "normal.png", keep(NormalColour(m.normal)), lin16,
                               "tangent-space normal, OpenGL +Y, rgb = n*0.5+0.5"));
    MATFIT_RETURN_IF_ERROR(
        put("normal_exact", "normal.exr", m.normal, exr, "unit normal xyz (float)"));
    // The height (the write's longest single job: a multigrid solve) is integrated and written
    // by a task of its own, the first to run, so that the other files encode beside it. Beyond
    // 4096² texels (the solve holds about 70 bytes a texel: 1.2 GB) the pack has no height map.
    if (int64_t(m.width) * m.height <= kMaxHeightTexels) {
      height_entry =
          describe("height_exact", "height.exr", 1, exr,
                   "height from the normals in texel units, mean 0 over the fitted texels "
                   "(least-squares integration, docs/pack.md)");
      describe("height", "height.png", 1, lin16,
               "the same height, 0 = range[0], 65535 = range[1] (texel units)");
      height_task = [&, maps_dir = root / "maps"] {
        return WriteHeightMaps(m, status, maps_dir, exr, lin16, &height_written, height_range);
      };
    }
  }
  MATFIT_RETURN_IF_ERROR(model.WritePackMaps(m, [&](const PackMap& pm) {
    const ImageWriteOptions wo = pm.encoding == MapEncoding::kSrgb8      ? srgb8
                                 : pm.encoding == MapEncoding::kLinear8  ? lin8
                                 : pm.encoding == MapEncoding::kLinear16 ? lin16
                                                                         : exr;
    // A descriptor's image need only live through this call: the maps of `m` are written from
    // where they are, anything else (a temporary made for the pack) is copied.
    const auto a = reinterpret_cast<uintptr_t>(pm.image), m0 = reinterpret_cast<uintptr_t>(&m);
    const bool member = a >= m0 && a < m0 + sizeof m;
    return put(pm.name, pm.file, member || pm.image->empty() ? *pm.image : keep(*pm.image), wo,
               pm.semantic);
  }));
  Image& status_img = owned.emplace_back(m.width, m.height, 1);
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
  // ρ_t / t, so a renderer with the extension reproduces the transmittance ρ_t. The base colour
  // is ρ_d itself, exact in viewers without the extension (three.js, Blender); one with it
  // reflects (1 − t) ρ_d (material.json "gltf_approximations"). Alpha = mask.
  const bool leaf = !m.translucency.empty();
  if (leaf) {
    const int64_t np = int64_t(m.width) * m.height;
    Image& base = owned.emplace_back(m.width, m.height, 4);
    Image& trans = owned.emplace_back(m.width, m.height, 4);
    auto lum = [](const Image& im, int64_t p) {
      return 0.2126 * im.Plane(0)[p] + 0.7152 * im.Plane(1)[p] + 0.0722 * im.Plane(2)[p];
    };
    for (int64_t p = 0; p < np; ++p) {
      const double ld = lum(m.albedo, p), lt = lum(m.translucency, p);
      const double tf = ld + lt > 1e-6 ? lt / (ld + lt) : 0.0;
      for (int c = 0; c < 3; ++c) {
        base.Plane(c)[p] = std::min(1.0f, m.albedo.Plane(c)[p]);
        trans.Plane(c)[p] = float(std::min(1.0, m.translucency.Plane(c)[p] / std::max(1e-6, tf)));
      }
      base.Plane(3)[p] = m.mask.empty() ? 1.0f : m.mask.Plane(0)[p];
      trans.Plane(3)[p] = float(tf);
    }
    MATFIT_RETURN_IF_ERROR(put("gltf_base_color", "gltf_base_color.png", base, srgb8,
                               "glTF base colour rho_d, alpha = mask"));
    MATFIT_RETURN_IF_ERROR(put("gltf_diffuse_transmission", "gltf_diffuse_transmission.png", trans,
                               srgb8, "glTF diffuse transmission: rgb = rho_t/t, a = t (linear)"));
    // The back-lit fallback (material_backlit.gltf): the transmittance as the base colour of a
    // quad whose normals face away from the viewer, alpha = mask.
    Image& backlit = owned.emplace_back(m.width, m.height, 4);
    for (int64_t p = 0; p < np; ++p) {
      for (int c = 0; c < 3; ++c) backlit.Plane(c)[p] = std::min(1.0f, m.translucency.Plane(c)[p]);
      backlit.Plane(3)[p] = m.mask.empty() ? 1.0f : m.mask.Plane(0)[p];
    }
    MATFIT_RETURN_IF_ERROR(put("gltf_backlit_color", "gltf_backlit_color.png", backlit, srgb8,
                               "glTF back-lit fallback base colour: rho_t, alpha = mask"));
  }
  // Relighting bases in glTF terms: the Lambert + GGX surface closest to the fit's own
  // prediction (core/pack/gltf_bake.h).
  const bool baked = model.gltf_baked();
  GltfF0 baked_f0;
  if (baked) {
    GltfBake bake = BakeBasisAsGgx(m, [&](int64_t done, int64_t total) {
      progress(bake_end * done / std::max<int64_t>(1, total));
      return true;
    });
    MATFIT_RETURN_IF_ERROR(put("gltf_base_color", "gltf_base_color.png", keep(bake.base), srgb8,
                               "glTF base colour: the fitted Lambert + GGX surface's albedo"));
    MATFIT_RETURN_IF_ERROR(put("gltf_normal", "gltf_normal.png", keep(NormalColour(bake.normal)),
                               lin16, "glTF normal of that surface, OpenGL +Y"));
    Image mr(m.width, m.height, 3);
    for (int64_t p = 0; p < mr.plane_size(); ++p)
      mr.Plane(0)[p] = 1.0f, mr.Plane(1)[p] = bake.roughness.Plane(0)[p];
    MATFIT_RETURN_IF_ERROR(put("gltf_metallic_roughness", "gltf_metallic_roughness.png", keep(mr),
                               lin8, "glTF: G = that surface's GGX roughness, B = metallic (0)"));
    baked_f0 = SplitF0ForGltf(bake.f0, m.mask);
    if (baked_f0.ior > 0)
      MATFIT_RETURN_IF_ERROR(put("gltf_specular", "gltf_specular.png", keep(baked_f0.share), srgb8,
                                 "glTF specular colour: that surface's F0 over the IOR's"));
  }
  json extras = json::array();
  for (const PackExtraFile& e : info.extra_files) {
    const fs::path rel(e.path);
    if (rel.empty() || rel.is_absolute() || std::find(rel.begin(), rel.end(), "..") != rel.end())
      return InvalidArgument("pack: extra file '" + e.path + "' must be a path inside the pack");
    fs::create_directories((root / rel).parent_path(), ec);
    if (ec)
      return IoError("cannot create '" + (root / rel).parent_path().string() +
                     "': " + ec.message());
    if (!e.image.empty())
      tasks.push_back(
          [path = (root / rel).string(), &e, &exr] { return WriteImage(path, e.image, exr); });
    else
      tasks.push_back([path = (root / rel).string(), &e] { return WriteFileAtomic(path, e.text); });
    extras.push_back({{"file", e.path}, {"role", e.role}});
  }
  tasks.push_back(
      [&] { return WriteImage((root / "preview.png").string(), Preview(m, status), srgb8); });
  json previews = json::array({"preview.png"});
  for (const auto& extra : info.previews) {  // (clang 14 cannot capture structured bindings)
    const Image* img = &extra.second;
    tasks.push_back([path = (root / extra.first).string(), img, &srgb8] {
      return WriteImage(path, *img, srgb8);
    });
    previews.push_back(extra.first);
  }
  // The shaders' parameter planes for the web viewer (core/pack/shader_params.h), made and
  // written beside the image files.
  json viewer;
  fs::create_directories(root / "viewer", ec);
  if (ec) return IoError("cannot create '" + (root / "viewer").string() + "': " + ec.message());
  tasks.insert(tasks.begin(), [&]() -> Status {  // the largest file: first
    auto sp = PackShaderParams(m);
    if (!sp.ok()) return sp.status();
    static_assert(std::endian::native == std::endian::little, "params.bin is little-endian");
    MATFIT_RETURN_IF_ERROR(
        WriteFileAtomic((root / "viewer" / "params.bin").string(),
                        std::string_view(reinterpret_cast<const char*>(sp->texels.data()),
                                         sp->texels.size() * sizeof(float))));
    if (sp->table_size > 0)
      MATFIT_RETURN_IF_ERROR(
          WriteFileAtomic((root / "viewer" / "basis_table.bin").string(),
                          std::string_view(reinterpret_cast<const char*>(sp->basis_table.data()),
                                           sp->basis_table.size() * sizeof(float))));
    viewer = {{"params", "viewer/params.bin"},
              {"encoding", "float32le rgba layers"},
              {"width", sp->width},
              {"height", sp->height},
              {"layers", sp->layers},
              {"model_index", sp->model},
              {"terms", sp->terms},
              {"coef_channels", sp->coef_channels},
              {"basis_srgb", sp->basis_srgb},
              {"heinrich_specular", sp->heinrich_specular},
              {"flat_normal", sp->flat_normal},
              {"leaf_base", sp->leaf_base},
              {"leaf_hl2", sp->leaf_hl2}};
    if (sp->table_size > 0)
      viewer["basis_table"] = "viewer/basis_table.bin", viewer["table_size"] = sp->table_size;
    return Status::Ok();
  });
  if (height_task && int64_t(m.width) * m.height > kHeightBesideFilesTexels)
    MATFIT_RETURN_IF_ERROR(height_task());  // alone: its memory goes back before the files'
  else if (height_task)
    tasks.insert(tasks.begin(), std::move(height_task));
  {
    std::vector<Status> written(tasks.size(), Status::Ok());
    std::atomic<int64_t> finished{0};
    ParallelFor(
        0, int64_t(tasks.size()),
        [&](int64_t t0, int64_t t1) {
          for (int64_t t = t0; t < t1; ++t) {
            written[size_t(t)] = tasks[size_t(t)]();
            progress(bake_end + (files_end - bake_end) * ++finished / int64_t(tasks.size()));
          }
        },
        1);
    for (const Status& st : written) MATFIT_RETURN_IF_ERROR(st);
  }
  // The height's two entries say its range, or go when IntegrateNormals made none.
  if (height_entry && height_written) {
    for (size_t e : {*height_entry, *height_entry + 1})
      maps[e]["range_texels"] = {height_range[0], height_range[1]};
  } else if (height_entry) {
    maps.erase(maps.begin() + ptrdiff_t(*height_entry) + 1);
    maps.erase(maps.begin() + ptrdiff_t(*height_entry));
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
  if (baked) {
    g.base_color_uri = "maps/gltf_base_color.png", g.normal_uri = "maps/gltf_normal.png";
    g.metallic_roughness_uri = "maps/gltf_metallic_roughness.png";
    if (baked_f0.ior > 0) {
      g.specular_factor = 1.0, g.ior = baked_f0.ior;
      g.specular_color_uri = "maps/gltf_specular.png";
    }
    g.approximations.push_back(
        "a relighting basis has no glTF form: the glTF shows the Lambert + GGX surface closest "
        "to the model's own prediction (normal, albedo, F0 and roughness fitted per texel to "
        "lights within 60 degrees of the view, core/pack/gltf_bake.h); what the basis holds "
        "beyond one lobe (shadows, interreflection, ringing) is left out");
  }
  model.Gltf(m, status, info.model_parameters, &g);
  const double mm = info.mm_per_texel > 0 ? info.mm_per_texel : 0.5;  // unknown: 0.5 mm/texel
  g.width_m = m.width * mm / 1000, g.height_m = m.height * mm / 1000;
  std::vector<uint8_t> bin;
  const std::string gltf = MakeQuadGltf(g, "quad.bin", &bin);
  MATFIT_RETURN_IF_ERROR(
      WriteFileAtomic((root / "quad.bin").string(), std::string(bin.begin(), bin.end())));
  MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "material.gltf").string(), gltf));
  // Leaves: a core-glTF file for light from behind (viewers without
  // KHR_materials_diffuse_transmission draw material.gltf black when lit from behind): the same
  // quad facing the viewer with its normals turned away, so only light from behind lights it,
  // with the transmittance ρ_t as its diffuse colour — a Lambertian transmission, ρ_t · |cos θ_l|
  // (matfit's DiffuseTranslucency; the HL2 lobe's directional profile is not carried).
  if (leaf) {
    GltfMaterialDesc b;
    b.name = info.method + " (lit from behind)";
    b.base_color_uri = "maps/gltf_backlit_color.png";
    b.specular_factor = 0.0, b.roughness = 1.0;
    b.normals_back = true, b.alpha_mask = !m.mask.empty();
    b.width_m = g.width_m, b.height_m = g.height_m;
    std::vector<uint8_t> back_bin;
    const std::string back = MakeQuadGltf(b, "quad_backlit.bin", &back_bin);
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "quad_backlit.bin").string(),
                                           std::string(back_bin.begin(), back_bin.end())));
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "material_backlit.gltf").string(), back));
    g.approximations.push_back(
        "leaf: the base colour is the reflectance rho_d, exact in viewers without "
        "KHR_materials_diffuse_transmission; a viewer with it reflects (1 - t) rho_d (t = the "
        "transmitted share, maps/gltf_diffuse_transmission.png alpha). Viewers without it draw "
        "material.gltf black when lit from behind: material_backlit.gltf is its core-glTF "
        "stand-in for light from behind (the transmittance as a Lambertian colour on a quad whose "
        "normals face away)");
  }

  // Per-view packs: each view a pack of its own (maps, glTF, preview), written in turn (each
  // write is parallel inside) into this pack's staging folder.
  json views = json::array();
  if (!info.views.empty()) {
    fs::create_directories(root / "views", ec);
    if (ec) return IoError("cannot create '" + (root / "views").string() + "': " + ec.message());
  }
  for (size_t v = 0; v < info.views.size(); ++v) {
    const PackView& pv = info.views[v];
    if (!pv.maps || !pv.status || pv.maps->width != m.width || pv.maps->height != m.height)
      return InvalidArgument("pack: view " + std::to_string(v) + " has no maps of the pack's size");
    char name[32];
    std::snprintf(name, sizeof name, "v%03u", unsigned(v));
    PackInfo vi;
    vi.method = info.method;
    vi.source = info.source;
    vi.model_parameters = pv.parameters ? *pv.parameters : info.model_parameters;
    vi.mm_per_texel = info.mm_per_texel;
    MATFIT_RETURN_IF_ERROR(WritePack(*pv.maps, *pv.status, vi, {false, false, options.compact},
                                     (root / "views" / name).string()));
    views.push_back({{"theta_deg", pv.theta_deg},
                     {"phi_deg", pv.phi_deg},
                     {"pack", std::string("views/") + name}});
    progress(files_end + (990 - files_end) * int64_t(v + 1) / int64_t(info.views.size()));
  }

  json params = json::object();
  for (const auto& [k, v] : info.model_parameters) params[k] = v;
  std::map<std::string, double> model_params;
  model.PackParameters(m, &model_params);
  for (const auto& [k, v] : model_params) params[k] = int64_t(v);  // counts and flags
  json report_summary = json::object();
  if (!info.report_json.empty()) {
    const json r = json::parse(info.report_json, nullptr, false);
    for (const char* k : {"deviation_percent", "rmse", "psnr_db", "flagged_texels", "fit_seconds"})
      if (r.is_object() && r.contains(k)) report_summary[k] = r[k];
  }
  // Files other tools open: PTM, HSH .rti, the relight web layout (core/pack/pack_exports.h).
  json exports = json::array();
  MATFIT_RETURN_IF_ERROR(WritePackExports(m, root.string(), &exports));
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
      {"gltf_backlit", leaf ? json("material_backlit.gltf") : json()},
      {"gltf_approximations", g.approximations},
      {"exports", exports},
      {"previews", previews},
      {"viewer", viewer},
      {"report", "report.json"},
      {"report_summary", report_summary},
      {"warnings", info.warnings},
      {"views", info.views.empty() ? json() : views},
      {"extras", extras},
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

  if (!options.zip) return dir.Commit();
  MATFIT_RETURN_IF_ERROR(dir.WriteMarker());
  MATFIT_RETURN_IF_ERROR(CheckOutput(out, options.overwrite));  // it may have appeared meanwhile
  AtomicFile zip_file(out);
  MATFIT_RETURN_IF_ERROR(ZipFolder(root.string(), zip_file.temp_path()));
  return zip_file.Commit();  // the staging folder is removed by ~AtomicDir
}

}  // namespace matfit
