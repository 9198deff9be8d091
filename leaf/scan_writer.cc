// WriteLeafScan: a synthetic scan as the files a leaf rig would leave (docs/formats.md).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/image_io.h"
#include "leaf/synthetic_scan.h"

namespace matfit::leaf {

Status WriteLeafScan(const SyntheticScan& s, const std::string& dir, bool overwrite,
                     const ProgressFn& progress) {
  namespace fs = std::filesystem;
  AtomicDir out(dir, "leaf-scan");
  MATFIT_RETURN_IF_ERROR(out.Begin(overwrite));
  const fs::path root(out.temp_path());
  const ImageWriteOptions png8{PixelFormat::kUint8, TransferFunction::kSrgb};
  const ImageWriteOptions exr{PixelFormat::kFloat, TransferFunction::kLinear};
  nlohmann::json m = {{"schema", "matfit.leafscan/1"},
                      {"back_lit", "*_BL.png"},
                      {"marker_size_mm", s.scan.marker_size_mm},
                      {"max_thickness_mm", s.scan.max_thickness_mm},
                      {"color_space", "srgb"}};
  const LightStack& top = s.scan.top;
  // Progress: photos (top-lit or front), back-lit images, then the 5 truth maps.
  const int64_t files = std::max(1, top.num_images()) + int64_t(s.scan.back.size()) + 5;
  int64_t written = 0;
  auto wrote = [&] {
    if (progress) progress(++written, files);
  };
  if (top.num_images() > 0) {
    std::string lp = std::to_string(top.num_images()) + "\n";
    for (int k = 0; k < top.num_images(); ++k) {
      Image img(top.width(), top.height(), top.channels());
      for (int c = 0; c < top.channels(); ++c) {
        float* dst = img.Plane(c).data();
        const float* src = top.Texels(k, c, 0, int(top.plane_size()), dst);  // decodes into dst
        if (src != dst) std::copy_n(src, top.plane_size(), dst);
      }
      MATFIT_RETURN_IF_ERROR(WriteImage((root / top.image_files[k]).string(), img, png8));
      wrote();
      const Vec3& d = top.lights()[k].direction;
      char line[160];
      std::snprintf(line, sizeof line, "%s %.6f %.6f %.6f\n", top.image_files[k].c_str(), d.x, d.y,
                    d.z);
      lp += line;
    }
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "top_lights.lp").string(), lp));
    m["top_lit"] = "top_lights.lp";
  } else {
    MATFIT_RETURN_IF_ERROR(WriteImage((root / "front.png").string(), s.scan.front, png8));
    wrote();
    m["front_lit"] = "front.png";
  }
  for (size_t k = 0; k < s.scan.back.size(); ++k) {
    MATFIT_RETURN_IF_ERROR(
        WriteImage((root / s.scan.back_files[k]).string(), s.scan.back[k], png8));
    wrote();
  }
  if (!s.scan.upper_displacement.empty()) {
    MATFIT_RETURN_IF_ERROR(
        WriteImage((root / "upper_displacement.exr").string(), s.scan.upper_displacement, exr));
    MATFIT_RETURN_IF_ERROR(
        WriteImage((root / "lower_displacement.exr").string(), s.scan.lower_displacement, exr));
    m["upper_displacement"] = "upper_displacement.exr";
    m["lower_displacement"] = "lower_displacement.exr";
    m["displacement_scale_mm"] = s.scan.displacement_scale_mm;
  }
  MATFIT_RETURN_IF_ERROR(WriteFileAtomic((root / "leaf.json").string(), m.dump(2) + "\n"));
  std::error_code ec;
  fs::create_directories(root / "truth", ec);
  if (ec) return IoError("cannot create '" + (root / "truth").string() + "': " + ec.message());
  const auto& t = s.truth;
  MATFIT_RETURN_IF_ERROR(WriteImage((root / "truth" / "albedo.exr").string(), t.albedo, exr));
  wrote();
  MATFIT_RETURN_IF_ERROR(WriteImage((root / "truth" / "normal.exr").string(), t.normal, exr));
  wrote();
  MATFIT_RETURN_IF_ERROR(
      WriteImage((root / "truth" / "translucency.exr").string(), t.translucency, exr));
  wrote();
  MATFIT_RETURN_IF_ERROR(WriteImage((root / "truth" / "thickness.exr").string(), t.thickness, exr));
  wrote();
  MATFIT_RETURN_IF_ERROR(WriteImage((root / "truth" / "mask.png").string(), t.mask,
                                    {PixelFormat::kUint8, TransferFunction::kLinear}));
  wrote();
  return out.Commit();
}

}  // namespace matfit::leaf
