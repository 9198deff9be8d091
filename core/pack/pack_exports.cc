#include "core/pack/pack_exports.h"

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <tuple>
#include <utility>
#include <vector>

#include "core/atomic_file.h"
#include "core/image_io.h"
#include "core/model/model.h"
#include "core/pack/ptm_export.h"
#include "core/pack/relight_export.h"
#include "core/pack/rti_export.h"
#include "core/parallel.h"

namespace matfit {

namespace fs = std::filesystem;

Status WritePackExports(const MaterialMaps& m, const std::string& root_path,
                        nlohmann::json* exports) {
  const fs::path root(root_path);
  // Every file is encoded and written by its own task, the tasks in parallel (JPEG planes and
  // PTM encodes were half of a ptm pack's write stage one after another); the entries are
  // appended afterwards in a fixed order, each only when its file was made.
  std::vector<std::function<Status()>> tasks;
  std::vector<std::pair<bool, nlohmann::json>> entries;  // (made, entry) in material.json order
  auto file_task = [&](std::function<StatusOr<std::string>()> encode, const std::string& file,
                       nlohmann::json entry) {
    const size_t e = entries.size();
    entries.push_back({false, std::move(entry)});
    tasks.push_back([&, e, encode = std::move(encode), path = (root / file).string()]() -> Status {
      auto bytes = encode();
      if (!bytes.ok()) return Status::Ok();  // this fit has no such export (e.g. not 6 terms)
      MATFIT_RETURN_IF_ERROR(WriteFileAtomic(path, *bytes));
      entries[e].first = true;
      return Status::Ok();
    });
  };
  if (HasRtiBasis(m.model, "ptm")) {
    const char* values = m.basis_srgb ? "8-bit sRGB codes, as RTI tools fit them"
                                      : "linear radiance x 255 (a viewer shows it darker than "
                                        "an sRGB fit; fit ptm-srgb for RTI viewers)";
    for (const auto& [format, file, name] :
         {std::tuple{PtmFormat::kRgb, "material.ptm", "PTM_1.2 PTM_FORMAT_RGB"},
          std::tuple{PtmFormat::kLrgb, "material_lrgb.ptm", "PTM_1.2 PTM_FORMAT_LRGB"}})
      file_task([&m, format = format] { return EncodePtm(m, format); }, file,
                {{"file", file}, {"format", name}, {"values", values}});
  }
  if (HasRtiBasis(m.model, "hsh"))  // hsh2 / hsh3 (RTI tools stop at 9 terms)
    file_task([&m] { return EncodeRti(m); }, "material.rti",
              {{"file", "material.rti"},
               {"format", "HSH 1.2 (RTIBuilder / RTIViewer .rti)"},
               {"values", m.basis_srgb ? "sRGB-encoded values in [0, 1], as RTI tools fit them"
                                       : "linear radiance (a viewer shows it darker than an sRGB "
                                         "fit; fit hsh2-srgb or hsh3-srgb for RTI viewers)"}});
  auto web = EncodeRelightWeb(m);
  // Quality 100 with full-resolution chroma: about one code of error per coefficient
  // (docs/pack.md); the planes are codes, stored as they are (no transfer curve).
  ImageWriteOptions jpg{PixelFormat::kUint8, TransferFunction::kLinear};
  jpg.jpeg_quality = 100;
  if (web.ok()) {
    const fs::path dir = root / "relight";
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return IoError("cannot create '" + dir.string() + "': " + ec.message());
    for (size_t i = 0; i < web->planes.size(); ++i)
      tasks.push_back([&, i, path = (dir / ("plane_" + std::to_string(i) + ".jpg")).string()] {
        return WriteImage(path, web->planes[i], jpg);
      });
    tasks.push_back(
        [&, path = (dir / "info.json").string()] { return WriteFileAtomic(path, web->info_json); });
  }
  std::vector<Status> done(tasks.size(), Status::Ok());
  ParallelFor(
      0, int64_t(tasks.size()),
      [&](int64_t t0, int64_t t1) {
        for (int64_t t = t0; t < t1; ++t) done[size_t(t)] = tasks[size_t(t)]();
      },
      1);
  for (const Status& st : done) MATFIT_RETURN_IF_ERROR(st);
  for (auto& [made, entry] : entries)
    if (made) exports->push_back(std::move(entry));
  if (web.ok())
    exports->push_back(
        {{"file", "relight/info.json"},
         {"format", "relight web layout (OpenLIME LayerRTI, layout \"image\"; relight-cli)"},
         {"planes", web->planes.size()},
         {"values", m.basis_srgb ? "sRGB-encoded values in [0, 1], as RTI tools fit them"
                                 : "linear radiance (a viewer shows it darker than an sRGB "
                                   "fit; fit an -srgb basis for RTI viewers)"}});
  return Status::Ok();
}

}  // namespace matfit
