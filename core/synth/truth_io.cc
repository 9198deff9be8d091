#include "core/synth/truth_io.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/image_io.h"
#include "core/model/model.h"
#include "core/path_util.h"

namespace matfit::synth {
namespace {
namespace fs = std::filesystem;
}

std::string FindTruthFolder(const std::string& source) {
  std::error_code ec;
  fs::path dir(source);
  if (fs::is_regular_file(dir, ec)) dir = dir.parent_path();
  const fs::path truth = dir / "truth";
  return fs::exists(truth / "params.json", ec) ? truth.string() : std::string();
}

StatusOr<MaterialMaps> ReadTruth(const std::string& dir, const std::string& confine_to) {
  MaterialMaps m;
  ImageReadOptions linear;
  linear.color_space = ColorSpaceChoice::kLinear;
  linear.confine_to = confine_to;
  auto read = [&](const char* name, bool required, Image* out) -> Status {
    const std::string path = (fs::path(dir) / name).string();
    std::error_code ec;
    if (!fs::exists(path, ec))
      return required ? NotFound("truth map '" + DatasetRelative(path, confine_to) + "' is missing")
                      : Status::Ok();
    auto img = ReadImage(path, linear);
    if (!img.ok()) return img.status();
    *out = std::move(*img);
    return Status::Ok();
  };
  MATFIT_RETURN_IF_ERROR(read("normal.exr", true, &m.normal));
  MATFIT_RETURN_IF_ERROR(read("albedo.exr", true, &m.albedo));
  MATFIT_RETURN_IF_ERROR(read("mask.png", true, &m.mask));
  MATFIT_RETURN_IF_ERROR(read("height.exr", false, &m.height_map));
  MATFIT_RETURN_IF_ERROR(read("specular.exr", false, &m.specular));
  MATFIT_RETURN_IF_ERROR(read("exponent.exr", false, &m.exponent));
  MATFIT_RETURN_IF_ERROR(read("roughness.exr", false, &m.roughness));
  MATFIT_RETURN_IF_ERROR(read("thickness.exr", false, &m.thickness));
  MATFIT_RETURN_IF_ERROR(read("translucency.exr", false, &m.translucency));
  // The generating model, so that fits of the same family can compare their parameters.
  // Optional: when it is missing or lies outside the sandbox, the model is just not known.
  auto pj_path = ResolveInDataset((fs::path(dir) / "params.json").string(), confine_to);
  std::ifstream pj(pj_path.ok() ? *pj_path : std::string());
  const nlohmann::json params = nlohmann::json::parse(pj, nullptr, false);
  if (params.is_object() && params.contains("model") && params["model"].is_object() &&
      params["model"].contains("name") && params["model"]["name"].is_string()) {
    const std::string name = params["model"]["name"].get<std::string>();
    if (const ModelDescriptor* d = FindModel(name); d && d->synthesizable()) m.model = d->id();
  }
  m.width = m.normal.width();
  m.height = m.normal.height();
  if (m.albedo.width() != m.width || m.mask.width() != m.width)
    return DataError("truth maps in '" + DatasetRelative(dir, confine_to) +
                     "' have different sizes");
  return m;
}

bool TruthMapsAreTheAppearance(const std::string& dir, const std::string& confine_to) {
  auto path = ResolveInDataset((fs::path(dir) / "params.json").string(), confine_to);
  std::ifstream in(path.ok() ? *path : std::string());
  const nlohmann::json params = nlohmann::json::parse(in, nullptr, false);
  return !(params.is_object() && params.contains("appearance") &&
           params["appearance"] == "micro-geometry");
}

}  // namespace matfit::synth
