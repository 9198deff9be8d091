#include "core/pack/pack_reader.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <tuple>

#include "core/image_io.h"
#include "core/model/model.h"
#include "core/path_util.h"
#include "core/vec3.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The string at o[key]: "" when absent, nullopt when present with another type (a hostile or
// hand-edited material.json must get an error naming the field, never an exception).
std::optional<std::string> StringField(const json& o, const char* key) {
  if (!o.is_object() || !o.contains(key)) return std::string();
  const json& v = o[key];
  if (!v.is_string()) return std::nullopt;
  return v.get<std::string>();
}

constexpr size_t kMaxPackViews = 65536;  // 151 × 151 Bonn views and more

// `confine`: the folder every file must resolve inside (the top-level pack's).
StatusOr<PackContents> ReadPackFolder(const std::string& dir, bool views_allowed,
                                      const std::string& confine);

// material.json "views": each entry's pack, read and checked against the pack's own size.
Status ReadPackViews(const std::string& dir, const std::string& mj, const json& jv,
                     PackContents* pc) {
  if (jv.is_null()) return Status::Ok();
  if (!jv.is_array() || jv.size() > kMaxPackViews)
    return DataError("'" + mj + "': field 'views' must be a list of at most " +
                     std::to_string(kMaxPackViews) + " views");
  for (size_t v = 0; v < jv.size(); ++v) {
    const json& e = jv[v];
    const std::string at = "'" + mj + "': views[" + std::to_string(v) + "]";
    const std::optional<std::string> pack = StringField(e, "pack");
    if (!e.is_object() || !pack || pack->empty() || !e.contains("theta_deg") ||
        !e["theta_deg"].is_number() || !e.contains("phi_deg") || !e["phi_deg"].is_number())
      return DataError(at + " needs numbers 'theta_deg', 'phi_deg' and a string 'pack'");
    const double theta = e["theta_deg"].get<double>(), phi = e["phi_deg"].get<double>();
    if (!(theta >= 0 && theta <= 90) || !std::isfinite(phi))
      return DataError(at + ": theta_deg must be in [0, 90] and phi_deg finite");
    const fs::path f(*pack);
    if (f.is_absolute() || std::find(f.begin(), f.end(), "..") != f.end())
      return DataError(at + " points outside the pack ('" + *pack +
                       "'); give a folder relative to the pack");
    // A view's folder, and every file it names, must lie inside this pack (no symlink out).
    const std::string folder = (fs::path(dir) / f).string();
    if (!PathWithin(folder, dir))
      return DataError(at + ": '" + *pack + "' resolves outside the pack folder");
    auto sub = ReadPackFolder(folder, /*views_allowed=*/false, dir);
    if (!sub.ok()) return Status(sub.status().code(), at + ": " + sub.status().message());
    if (sub->maps.width != pc->maps.width || sub->maps.height != pc->maps.height)
      return DataError(at + ": its maps are " + std::to_string(sub->maps.width) + " x " +
                       std::to_string(sub->maps.height) + ", the pack's " +
                       std::to_string(pc->maps.width) + " x " + std::to_string(pc->maps.height));
    pc->views.push_back({theta, phi, std::move(sub->maps), std::move(sub->status)});
  }
  return Status::Ok();
}

}  // namespace

int NearestPackView(const PackContents& pack, double theta_deg, double phi_deg) {
  const Vec3 d = DirectionFromAnglesDeg(theta_deg, phi_deg);
  int best = -1;
  double best_cos = -2;
  for (size_t v = 0; v < pack.views.size(); ++v) {
    const double c = Dot(DirectionFromAnglesDeg(pack.views[v].theta_deg, pack.views[v].phi_deg), d);
    if (c > best_cos + 1e-12) best = int(v), best_cos = c;
  }
  return best;
}

StatusOr<PackContents> ReadPack(const std::string& dir) { return ReadPackFolder(dir, true, dir); }

namespace {

StatusOr<PackContents> ReadPackFolder(const std::string& dir, bool views_allowed,
                                      const std::string& confine) {
  const std::string mj = (fs::path(dir) / "material.json").string();
  if (confine != dir && !PathWithin(mj, confine))  // a view's material.json linked out
    return DataError("'" + mj + "' resolves outside the pack folder");
  std::ifstream in(mj);
  if (!in) return NotFound("'" + mj + "' not found: is '" + dir + "' a material pack folder?");
  const json j = json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return DataError("'" + mj + "' is not valid JSON");
  if (StringField(j, "schema") != "matfit.material/1")
    return DataError("'" + mj + "': field 'schema' must be \"matfit.material/1\"");
  PackContents pc;
  if (!j.contains("model") || !j["model"].is_object())
    return DataError("'" + mj + "': field 'model' must be an object with a 'name'");
  const json& jm = j["model"];
  const std::optional<std::string> model = StringField(jm, "name");
  if (!model) return DataError("'" + mj + "': field 'model.name' must be a string");
  const ModelDescriptor* descriptor = FindModel(*model);
  if (!descriptor) return DataError("'" + mj + "': unknown model.name '" + *model + "'");
  pc.maps.model = descriptor->id();
  const std::optional<std::string> method = StringField(jm, "method");
  if (!method) return DataError("'" + mj + "': field 'model.method' must be a string");
  pc.method = method->empty() ? *model : *method;
  if (!j.contains("maps") || !j["maps"].is_array())
    return DataError("'" + mj + "': field 'maps' must be a list");
  std::map<std::string, std::string> files;
  for (const auto& e : j["maps"]) {
    const std::optional<std::string> name = StringField(e, "name"), file = StringField(e, "file");
    if (!e.is_object() || !name || !file)
      return DataError("'" + mj + "': every entry of 'maps' needs a string 'name' and 'file'");
    if (name->empty() || file->empty()) continue;
    const fs::path f(*file);
    if (f.is_absolute() || std::find(f.begin(), f.end(), "..") != f.end())
      return DataError("'" + mj + "': map '" + *name + "' points outside the pack ('" + *file +
                       "'); give a path relative to the pack folder");
    files[*name] = *file;
  }
  ImageReadOptions linear;
  linear.color_space = ColorSpaceChoice::kLinear;
  linear.all_channels = true;
  auto load = [&](const std::string& name, Image* out, bool as_stored = true) -> Status {
    auto it = files.find(name);
    if (it == files.end()) return Status::Ok();
    ImageReadOptions o;
    if (as_stored) o = linear;  // data maps; colour maps go through the file's sRGB tag
    o.confine_to = confine;     // a symlink out of the pack is refused, never opened
    auto img = ReadImage((fs::path(dir) / it->second).string(), o);
    if (!img.ok())  // say which entry of material.json named the file
      return Status(img.status().code(),
                    "'" + mj + "': map '" + name + "': " + img.status().message() +
                        " (the pack's maps must be files inside the pack folder)");
    *out = std::move(*img);
    return Status::Ok();
  };
  MaterialMaps& m = pc.maps;
  if (files.count("albedo_exact"))
    MATFIT_RETURN_IF_ERROR(load("albedo_exact", &m.albedo));
  else
    MATFIT_RETURN_IF_ERROR(load("albedo", &m.albedo, false));
  if (m.albedo.empty()) return DataError("'" + mj + "' lists no albedo map");
  if (files.count("normal_exact")) {
    MATFIT_RETURN_IF_ERROR(load("normal_exact", &m.normal));
  } else if (files.count("normal")) {
    MATFIT_RETURN_IF_ERROR(load("normal", &m.normal));
    for (float& v : m.normal.data()) v = 2 * v - 1;
  } else {
    m.normal = Image(m.albedo.width(), m.albedo.height(), 3);
    for (float& v : m.normal.Plane(2)) v = 1.0f;
  }
  MATFIT_RETURN_IF_ERROR(load("mask", &m.mask));
  MATFIT_RETURN_IF_ERROR(load("thickness", &m.thickness));
  MATFIT_RETURN_IF_ERROR(load("translucency", &m.translucency));
  MATFIT_RETURN_IF_ERROR(load("albedo_back", &m.albedo_back));
  MATFIT_RETURN_IF_ERROR(load("hl2", &m.hl2));
  m.width = m.albedo.width();
  m.height = m.albedo.height();
  // The texel maps every reader indexes by the albedo's texels: the same size, enough channels.
  auto sized = [&](const char* name, const Image& img, int channels) -> Status {
    if (img.empty() ||
        (img.width() == m.width && img.height() == m.height && img.channels() >= channels))
      return Status::Ok();
    return DataError("'" + mj + "': map '" + name + "' is " + std::to_string(img.width()) + " x " +
                     std::to_string(img.height()) + " with " + std::to_string(img.channels()) +
                     " channel(s); it must be the albedo's size (" + std::to_string(m.width) +
                     " x " + std::to_string(m.height) + ") with at least " +
                     std::to_string(channels));
  };
  for (const auto& [name, img, channels] : {std::tuple{"normal", &m.normal, 3},
                                            {"mask", &m.mask, 1},
                                            {"thickness", &m.thickness, 1},
                                            {"translucency", &m.translucency, 1},
                                            {"albedo_back", &m.albedo_back, 1},
                                            {"hl2", &m.hl2, 1}})
    MATFIT_RETURN_IF_ERROR(sized(name, *img, channels));
  std::map<std::string, double> params;
  const json jp = jm.contains("parameters") ? jm["parameters"] : json::object();
  if (jp.is_object())
    for (const auto& [k, v] : jp.items())
      if (v.is_number()) params[k] = v.get<double>();
  if (Status st = descriptor->ReadPackMaps(
          [&](const char* name, Image* out) { return load(name, out); }, params, &m);
      !st.ok())
    return Status(st.code(), "'" + mj + "': " + st.message());
  Image status;
  MATFIT_RETURN_IF_ERROR(load("status", &status));
  MATFIT_RETURN_IF_ERROR(sized("status", status, 1));
  pc.status.assign(size_t(m.width) * m.height, 0);
  if (!status.empty())
    for (size_t p = 0; p < pc.status.size(); ++p)
      pc.status[p] = uint8_t(std::lround(status.data()[p] * 255));
  if (j.contains("views") && !j["views"].is_null()) {
    if (!views_allowed)
      return DataError("'" + mj + "': a view's pack cannot hold views of its own");
    MATFIT_RETURN_IF_ERROR(ReadPackViews(dir, mj, j["views"], &pc));
  }
  return pc;
}

}  // namespace

}  // namespace matfit
