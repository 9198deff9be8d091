#include "core/pack/pack_exports.h"

#include <filesystem>
#include <nlohmann/json.hpp>
#include <tuple>

#include "core/atomic_file.h"
#include "core/image_io.h"
#include "core/pack/ptm_export.h"
#include "core/pack/relight_export.h"
#include "core/pack/rti_export.h"

namespace matfit {

namespace fs = std::filesystem;

Status WritePackExports(const MaterialMaps& m, const std::string& root_path,
                        nlohmann::json* exports) {
  const fs::path root(root_path);
  if (m.model == ShadingModel::kPtm) {
    const char* values = m.basis_srgb ? "8-bit sRGB codes, as RTI tools fit them"
                                      : "linear radiance x 255 (a viewer shows it darker than "
                                        "an sRGB fit; fit ptm-srgb for RTI viewers)";
    for (const auto& [format, file, name] :
         {std::tuple{PtmFormat::kRgb, "material.ptm", "PTM_1.2 PTM_FORMAT_RGB"},
          std::tuple{PtmFormat::kLrgb, "material_lrgb.ptm", "PTM_1.2 PTM_FORMAT_LRGB"}}) {
      auto bytes = EncodePtm(m, format);
      if (!bytes.ok()) break;  // not a 6-term ptm of 1 or 3 channels
      MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / file).string(), *bytes));
      exports->push_back({{"file", file}, {"format", name}, {"values", values}});
    }
  }
  if (m.model == ShadingModel::kHsh) {
    if (auto bytes = EncodeRti(m); bytes.ok()) {  // hsh2 / hsh3 (RTI tools stop at 9 terms)
      MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "material.rti").string(), *bytes));
      exports->push_back(
          {{"file", "material.rti"},
           {"format", "HSH 1.2 (RTIBuilder / RTIViewer .rti)"},
           {"values", m.basis_srgb ? "sRGB-encoded values in [0, 1], as RTI tools fit them"
                                   : "linear radiance (a viewer shows it darker than an sRGB "
                                     "fit; fit hsh2-srgb or hsh3-srgb for RTI viewers)"}});
    }
  }
  if (auto web = EncodeRelightWeb(m); web.ok()) {
    const fs::path dir = root / "relight";
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return IoError("cannot create '" + dir.string() + "': " + ec.message());
    // Quality 100 with full-resolution chroma: about one code of error per coefficient
    // (docs/pack.md); the planes are codes, stored as they are (no transfer curve).
    ImageWriteOptions jpg{PixelFormat::kUint8, TransferFunction::kLinear};
    jpg.jpeg_quality = 100;
    for (size_t i = 0; i < web->planes.size(); ++i)
      MATFIT_RETURN_IF_ERROR(WriteImage((dir / ("plane_" + std::to_string(i) + ".jpg")).string(),
                                        web->planes[i], jpg));
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic((dir / "info.json").string(), web->info_json));
    exports->push_back(
        {{"file", "relight/info.json"},
         {"format", "relight web layout (OpenLIME LayerRTI, layout \"image\"; relight-cli)"},
         {"planes", web->planes.size()},
         {"values", m.basis_srgb ? "sRGB-encoded values in [0, 1], as RTI tools fit them"
                                 : "linear radiance (a viewer shows it darker than an sRGB "
                                   "fit; fit an -srgb basis for RTI viewers)"}});
  }
  return Status::Ok();
}

}  // namespace matfit
