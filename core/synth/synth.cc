#include "core/synth/synth.h"

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/dataset/writer.h"
#include "core/image_io.h"
#include "core/model/model.h"
#include "core/synth/light_sets.h"
#include "core/synth/materials.h"
#include "core/synth/micro_geometry.h"
#include "core/synth/render_stack.h"
#include "core/synth/render_views.h"
#include "core/version.h"

namespace matfit::synth {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json LightsJson(const std::vector<LightSample>& lights) {
  json arr = json::array();
  for (const auto& l : lights) {
    arr.push_back({{"direction", {l.direction.x, l.direction.y, l.direction.z}},
                   {"theta_deg", l.theta_deg},
                   {"phi_deg", l.phi_deg},
                   {"intensity", {l.intensity.x, l.intensity.y, l.intensity.z}}});
    if (l.has_position) arr.back()["position_px"] = {l.position.x, l.position.y, l.position.z};
  }
  return arr;
}

std::string ParamsJson(const SynthOptions& o, const SynthResult& r) {
  const MaterialInfo* info = FindMaterial(o.material);
  const ModelDescriptor& truth_model = Model(r.truth.model);
  json model = {{"name", truth_model.name()},
                {"reflectance_units", "R = pi * f_r * max(0, n.l); pixel = intensity * R"}};
  if (*truth_model.truth_formula()) model["specular"] = truth_model.truth_formula();
  json maps = {{"normal", "normal.exr (xyz, +Y up) / normal.png (16-bit, n*0.5+0.5)"},
               {"albedo", "albedo.exr (linear) / albedo.png (sRGB)"},
               {"height", "height.exr (texel units)"},
               {"mask", "mask.png"}};
  if (!r.truth.specular.empty()) maps["specular"] = truth_model.truth_specular_semantic();
  if (!r.truth.exponent.empty()) maps["exponent"] = "exponent.exr";
  if (!r.truth.roughness.empty()) maps["roughness"] = "roughness.exr (perceptual, alpha = r^2)";
  if (!r.truth.thickness.empty()) maps["thickness"] = "thickness.exr (mm)";
  if (!r.truth.translucency.empty()) maps["translucency"] = "translucency.exr (linear RGB)";
  json j = {
      {"generator", {{"name", "matfit synth"}, {"version", kMatfitVersion}}},
      {"material", {{"name", o.material}, {"description", info ? info->description : ""}}},
      {"model", model},
      {"maps", maps},
      {"size", o.size},
      {"width", o.size},
      {"height", o.rows()},
      {"seed", o.seed},
      {"light_set", o.lights},
      {"layout", LayoutName(o.layout)},
      {"bits", o.bits},
      {"format", o.format},
      {"encoding", o.format == "jpg" ? "sRGB 8-bit JPEG"
                   : o.bits == 8     ? "sRGB 8-bit PNG"
                   : o.bits == 16    ? "linear 16-bit PNG"
                                     : "linear float EXR"},
      {"view_direction",
       {r.stack.view_direction.x, r.stack.view_direction.y, r.stack.view_direction.z}},
      {"perturbations",
       {{"cast_shadows", r.cast_shadows},
        {"gaussian_sigma", o.perturb.gaussian_sigma},
        {"shot_photons", o.perturb.shot_photons},
        {"clip", o.perturb.clip},
        {"clipped_samples", r.perturb.clipped_samples},
        {"misregister_px", o.perturb.misregister_px},
        {"shift_x_px", r.perturb.shift_x},
        {"shift_y_px", r.perturb.shift_y}}},
      {"near_lights_px", o.near_lights},
      {"lights", LightsJson(r.stack.lights())},
  };
  if (!o.views.empty()) {
    json views = json::array();
    const int nl = r.stack.num_images() / std::max<int>(1, r.views.size());
    for (size_t k = 0; k < r.views.size(); ++k) {
      const LightSample& l = r.stack.lights()[k * size_t(nl)];
      views.push_back({{"direction", {l.view.x, l.view.y, l.view.z}},
                       {"theta_deg", l.view_theta_deg},
                       {"phi_deg", l.view_phi_deg}});
    }
    j["view_set"] = o.views;
    j["views"] = views;
    j["lights"] = LightsJson(
        std::vector<LightSample>(r.stack.lights().begin(), r.stack.lights().begin() + nl));
    j["rectified"] =
        "every view resampled to the reference plane: texel (x, y) shows the first point of the "
        "height field on the camera ray through (x, y, 0) (parallax and masking)";
  }
  std::map<std::string, double> truth_params;
  truth_model.TruthParameters(r.truth, &truth_params);
  for (const auto& [k, v] : truth_params) j["model"][k] = float(v);
  // "model-family": the images are the truth maps' model; "micro-geometry": they are not (the
  // maps are the macro normal and albedo only, for normal and albedo comparisons).
  j["appearance"] = info && info->micro_geometry ? "micro-geometry" : "model-family";
  if (info && info->micro_geometry) {
    const MicroGeometryOptions mo;
    j["model"] = {{"name", "micro-geometry (no fitted model's formula)"},
                  {"reflectance_units", "R = pi * L_out for a unit light; pixel = intensity * R"},
                  {"facets_per_texel_side", mo.sub},
                  {"bump_height_texels", mo.bump_height},
                  {"relief_texels", mo.relief},
                  {"facet_reflectance", "Lambertian base + Phong coat, Schlick Fresnel"},
                  {"facet_ior", mo.ior},
                  {"facet_lobe_exponent", mo.lobe_exponent},
                  {"transport", "ray-traced self-shadowing and masking, one diffuse bounce"}};
  }
  return j.dump(2) + "\n";
}

Image NormalAsColour(const Image& n) {
  Image out(n.width(), n.height(), 3);
  for (size_t i = 0; i < n.data().size(); ++i) out.data()[i] = n.data()[i] * 0.5f + 0.5f;
  return out;
}

Status WriteTruth(const MaterialMaps& m, const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return IoError("cannot create '" + dir + "': " + ec.message());
  const ImageWriteOptions exr{PixelFormat::kFloat, TransferFunction::kLinear};
  auto put = [&](const char* name, const Image& img) {
    return img.empty() ? Status::Ok() : WriteImage((fs::path(dir) / name).string(), img, exr);
  };
  MATFIT_RETURN_IF_ERROR(put("normal.exr", m.normal));
  MATFIT_RETURN_IF_ERROR(put("albedo.exr", m.albedo));
  MATFIT_RETURN_IF_ERROR(put("height.exr", m.height_map));
  MATFIT_RETURN_IF_ERROR(put("specular.exr", m.specular));
  MATFIT_RETURN_IF_ERROR(put("exponent.exr", m.exponent));
  MATFIT_RETURN_IF_ERROR(put("roughness.exr", m.roughness));
  MATFIT_RETURN_IF_ERROR(put("thickness.exr", m.thickness));
  MATFIT_RETURN_IF_ERROR(put("translucency.exr", m.translucency));
  MATFIT_RETURN_IF_ERROR(WriteImage((fs::path(dir) / "normal.png").string(),
                                    NormalAsColour(m.normal),
                                    {PixelFormat::kUint16, TransferFunction::kLinear}));
  MATFIT_RETURN_IF_ERROR(WriteImage((fs::path(dir) / "albedo.png").string(), m.albedo,
                                    {PixelFormat::kUint8, TransferFunction::kSrgb}));
  return WriteImage((fs::path(dir) / "mask.png").string(), m.mask,
                    {PixelFormat::kUint8, TransferFunction::kLinear});
}

}  // namespace

bool SynthOptions::Check(std::string* why) const {
  if (!FindMaterial(material)) {
    std::string list;
    for (const auto& m : Materials()) list += (list.empty() ? "" : ", ") + m.name;
    *why = "--material '" + material + "' is unknown; choose one of: " + list;
    return false;
  }
  if (!(near_lights == 0 || (near_lights > 0 && near_lights <= 1e7))) {
    *why = "--near-lights must be 0 (distant) or a distance in texels in (0, 1e7], got " +
           std::to_string(near_lights);
    return false;
  }
  if (size < 4 || size > 8192) {
    *why = "--size must be in [4, 8192], got " + std::to_string(size);
    return false;
  }
  if (height != 0 && (height < 4 || height > 8192)) {
    *why = "--size height must be in [4, 8192], got " + std::to_string(height);
    return false;
  }
  if (bits != 8 && bits != 16 && bits != 32) {
    *why = "--bits must be 8, 16 or 32, got " + std::to_string(bits);
    return false;
  }
  if (layout == Layout::kAuto) {
    *why = "--layout must be one of bonn, utia, lp, diligent, lights-txt";
    return false;
  }
  if (!views.empty() && layout != Layout::kBonn && layout != Layout::kUtia &&
      layout != Layout::kLp) {
    *why = "--views needs --layout bonn, utia or lp (the layouts that give each image's view)";
    return false;
  }
  if (!views.empty() && near_lights > 0) {
    *why = "--views renders distant lights only; drop --near-lights";
    return false;
  }
  if (!views.empty() && FindMaterial(material)->micro_geometry) {
    *why = "--views: material '" + material + "' is rendered from micro-geometry for one view only";
    return false;
  }
  DatasetWriteOptions wo;  // the file format against the bit depth
  wo.layout = layout, wo.bits = bits, wo.format = format;
  if (!wo.Check(why)) return false;
  return perturb.Check(why);
}

StatusOr<RenderedMaterial> RenderMaterial(const std::string& material, int width, int height,
                                          uint64_t seed, const std::vector<LightSample>& lights,
                                          bool shadows, const ProgressFn& progress) {
  const MaterialInfo* info = FindMaterial(material);
  RenderedMaterial r;
  if (info && info->micro_geometry) {
    auto surface = MakeMicroSurface(width, height, seed);
    if (!surface.ok()) return surface.status();
    r.truth = MicroTruthMaps(*surface);
    r.cast_shadows = true;  // part of its light transport
    r.stack = RenderMicroStack(*surface, lights, {0, 0, 1}, progress);
    r.micro_surface = std::make_shared<const MicroSurface>(std::move(*surface));
    return r;
  }
  auto maps = MakeMaterial(material, width, height, seed);  // names the known materials if unknown
  if (!maps.ok()) return maps.status();
  r.truth = std::move(*maps);
  r.cast_shadows = shadows || info->self_shadowing;
  RenderOptions ro;
  ro.cast_shadows = r.cast_shadows;
  r.stack = RenderStack(r.truth, lights, ro, progress);
  return r;
}

StatusOr<SynthResult> Synthesize(const SynthOptions& o, const ProgressFn& progress) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  auto lights = MakeLightSet(o.lights, o.seed);
  if (!lights.ok()) return lights.status();
  // BTF layouts store the angles in the file names: quantise so names and pixels agree.
  if (o.layout == Layout::kBonn || o.layout == Layout::kUtia) QuantizeToIntegerDegrees(&*lights);
  if (o.near_lights > 0) {
    if (const MaterialInfo* info = FindMaterial(o.material); info && info->micro_geometry)
      return InvalidArgument("--near-lights: material '" + o.material +
                             "' is rendered from micro-geometry with distant lights only");
    for (LightSample& l : *lights) l.has_position = true, l.position = l.direction * o.near_lights;
  }
  SynthResult r;
  if (!o.views.empty()) {  // every view × light, rectified (render_views.h)
    auto views = MakeLightSet(o.views, o.seed + 1);
    if (!views.ok()) return InvalidArgument("--views: " + std::string(views.status().message()));
    QuantizeToIntegerDegrees(&*views);
    for (const LightSample& v : *views) {
      if (v.theta_deg >= 85)
        return InvalidArgument("--views '" + o.views + "' has a view at θ " +
                               std::to_string(v.theta_deg) + "°; every view must be at θ < 85°");
      r.views.push_back(v.direction);
    }
    auto maps = MakeMaterial(o.material, o.size, o.rows(), o.seed);
    if (!maps.ok()) return maps.status();
    r.truth = std::move(*maps);
    r.cast_shadows = o.shadows || FindMaterial(o.material)->self_shadowing;
    r.stack = RenderViews(r.truth, *lights, r.views, r.cast_shadows, progress);
  } else {
    auto rendered =
        RenderMaterial(o.material, o.size, o.rows(), o.seed, *lights, o.shadows, progress);
    if (!rendered.ok()) return rendered.status();
    r.truth = std::move(rendered->truth);
    r.stack = std::move(rendered->stack);
    r.micro_surface = std::move(rendered->micro_surface);
    r.cast_shadows = rendered->cast_shadows;
  }
  PerturbOptions po = o.perturb;
  po.seed = o.seed;
  r.perturb = ApplyPerturbations(po, &r.stack);
  r.stack.layout = LayoutName(o.layout);
  r.stack.object_name = o.material;
  r.params_json = ParamsJson(o, r);
  return r;
}

Status WriteSynthDataset(const SynthResult& r, const SynthOptions& o, const std::string& out_dir,
                         bool overwrite, const ProgressFn& progress) {
  AtomicDir dir(out_dir, "dataset");
  MATFIT_RETURN_IF_ERROR(dir.Begin(overwrite));
  DatasetWriteOptions wo;
  wo.layout = o.layout;
  wo.bits = o.bits;
  wo.format = o.format;
  wo.object_name = fs::path(out_dir).filename().string();
  if (wo.object_name.empty()) wo.object_name = fs::path(out_dir).parent_path().filename().string();
  MATFIT_RETURN_IF_ERROR(WriteDataset(r.stack, wo, dir.temp_path(), progress));
  const std::string truth = (fs::path(dir.temp_path()) / "truth").string();
  MATFIT_RETURN_IF_ERROR(WriteTruth(r.truth, truth));
  MATFIT_RETURN_IF_ERROR(
      WriteFileAtomic((fs::path(truth) / "params.json").string(), r.params_json));
  return dir.Commit();
}

}  // namespace matfit::synth
