#include "core/dataset/writer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>

#include "core/atomic_file.h"
#include "core/dataset/btf_names.h"
#include "core/image_io.h"
#include "core/parallel.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

std::string Num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

ImageWriteOptions ImageOptions(int bits) {
  if (bits == 8) return {PixelFormat::kUint8, TransferFunction::kSrgb};
  if (bits == 16) return {PixelFormat::kUint16, TransferFunction::kLinear};
  return {PixelFormat::kFloat, TransferFunction::kLinear};
}

std::string Extension(const DatasetWriteOptions& o) {
  if (o.format == "jpg") return ".jpg";
  return o.bits == 32 ? ".exr" : ".png";
}

Image ImageOf(const LightStack& s, int i) {
  Image img(s.width(), s.height(), s.channels());
  for (int c = 0; c < s.channels(); ++c) {
    float* dst = img.Plane(c).data();
    const float* src = s.Texels(i, c, 0, int(s.plane_size()), dst);  // decodes into dst
    if (src != dst) std::copy_n(src, s.plane_size(), dst);
  }
  return img;
}

Status WriteMask(const LightStack& s, const std::string& path) {
  Image m(s.width(), s.height(), 1, 1.0f);
  if (s.has_mask())
    for (int64_t p = 0; p < s.plane_size(); ++p) m.data()[p] = s.mask[p] ? 1.0f : 0.0f;
  return WriteImage(path, m, {PixelFormat::kUint8, TransferFunction::kLinear});
}

// Writes every image to the path given by name(i), in parallel; first error wins.
Status WriteImages(const LightStack& s, int bits, const std::function<std::string(int)>& name,
                   const ProgressFn& progress) {
  std::vector<Status> errors(s.num_images());
  std::atomic<int64_t> written{0};
  ParallelFor(0, s.num_images(), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      errors[i] = WriteImage(name(int(i)), ImageOf(s, int(i)), ImageOptions(bits));
      if (progress) progress(++written, s.num_images());
    }
  });
  for (auto& st : errors) MATFIT_RETURN_IF_ERROR(st);
  return Status::Ok();
}

}  // namespace

bool DatasetWriteOptions::Check(std::string* why) const {
  if (bits != 8 && bits != 16 && bits != 32) {
    *why = "--bits must be 8, 16 or 32, got " + std::to_string(bits);
    return false;
  }
  if (format != "auto" && format != "png" && format != "jpg" && format != "exr") {
    *why = "--format must be auto, png, jpg or exr, got '" + format + "'";
    return false;
  }
  if ((format == "jpg" && bits != 8) || (format == "png" && bits == 32) ||
      (format == "exr" && bits != 32)) {
    *why = "--format " + format + " cannot hold --bits " + std::to_string(bits) +
           " (jpg: 8; png: 8 or 16; exr: 32)";
    return false;
  }
  if (layout == Layout::kAuto) {
    *why = "--layout must name a layout to write (bonn, utia, lp, diligent, lights-txt)";
    return false;
  }
  if (layout == Layout::kLightsTxt &&
      (object_name.empty() || object_name.find('/') != std::string::npos)) {
    *why = "lights-txt layout needs a plain object name, got '" + object_name + "'";
    return false;
  }
  return true;
}

std::string FormatLightPositions(const std::vector<Vec3>& positions) {
  std::string txt =
      "# light positions: x right, y up, z toward the camera; origin at the image centre; "
      "source pixels\n" +
      std::to_string(positions.size()) + "\n";
  char line[128];
  for (const Vec3& p : positions) {
    std::snprintf(line, sizeof line, "%.6f %.6f %.6f\n", p.x, p.y, p.z);
    txt += line;
  }
  return txt;
}

Status WriteDataset(const LightStack& s, const DatasetWriteOptions& o, const std::string& dir,
                    const ProgressFn& progress) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const fs::path d(dir);
  if (s.is_multi_view() && o.layout != Layout::kBonn && o.layout != Layout::kUtia &&
      o.layout != Layout::kLp)
    return InvalidArgument(std::string("a multi-view stack is written in the bonn, utia or lp "
                                       "layout (they give each image's view), not ") +
                           LayoutName(o.layout));
  if (s.has_light_positions()) {
    std::vector<Vec3> positions;
    for (const LightSample& l : s.lights()) positions.push_back(l.position);
    MATFIT_RETURN_IF_ERROR(
        WriteFileAtomic((d / "light_positions.txt").string(), FormatLightPositions(positions)));
  }
  const std::string ext = Extension(o);
  const int n = s.num_images();
  switch (o.layout) {
    case Layout::kBonn:
    case Layout::kUtia: {
      const bool bonn = o.layout == Layout::kBonn;
      std::vector<BtfName> names(n);
      for (int i = 0; i < n; ++i) {
        const LightSample& l = s.lights()[i];
        const double tv = l.has_view ? l.view_theta_deg : s.view_theta_deg;
        const double pv = l.has_view ? l.view_phi_deg : s.view_phi_deg;
        names[i] = {i, l.theta_deg, l.phi_deg, tv, pv};
        auto integral = [](double a) { return std::abs(a - std::round(a)) < 1e-6; };
        if (bonn && l.has_view && !(integral(tv) && integral(pv)))
          return InvalidArgument(
              "the Bonn layout stores view angles in integer degrees but image " +
              std::to_string(i) + " is seen from θv=" + Num(tv) + "°, φv=" + Num(pv) +
              "°; quantise the views or use --layout utia");
        if (!(integral(l.theta_deg) && integral(l.phi_deg)))
          return InvalidArgument(std::string("the ") + (bonn ? "Bonn" : "UTIA") +
                                 " layout stores light angles in integer degrees but light " +
                                 std::to_string(i) + " is at θ=" + Num(l.theta_deg) + "°, φ=" +
                                 Num(l.phi_deg) + "°; quantise the lights or use --layout lp");
      }
      // Bonn: one folder per view ("tv030_pv060"); UTIA: every image in the folder, its view in
      // its name.
      std::vector<fs::path> folders(size_t(n), d);
      if (bonn)
        for (int i = 0; i < n; ++i) {
          folders[size_t(i)] = d / MakeBonnViewFolder(names[i].theta_v, names[i].phi_v);
          if (i > 0 && folders[size_t(i)] == folders[size_t(i) - 1]) continue;
          std::error_code ec;
          fs::create_directories(folders[size_t(i)], ec);
          if (ec)
            return IoError("cannot create '" + folders[size_t(i)].string() + "': " + ec.message());
        }
      return WriteImages(
          s, o.bits,
          [&](int i) {
            return (folders[size_t(i)] /
                    (bonn ? MakeBonnName(i, names[i], ext) : MakeUtiaName(names[i], ext)))
                .string();
          },
          progress);
    }
    case Layout::kLp: {
      // A multi-view stack: "N views", each line ending in its image's view direction.
      const bool views = s.is_multi_view();
      std::string lp = std::to_string(n) + (views ? " views\n" : "\n");
      for (int i = 0; i < n; ++i) {
        const Vec3& l = s.lights()[i].direction;
        char name[32];
        std::snprintf(name, sizeof name, "img_%03d%s", i, ext.c_str());
        lp += std::string(name) + " " + Num(l.x) + " " + Num(l.y) + " " + Num(l.z);
        if (views) {
          const Vec3 v = s.ViewOf(i);
          lp += " " + Num(v.x) + " " + Num(v.y) + " " + Num(v.z);
        }
        lp += "\n";
      }
      MATFIT_RETURN_IF_ERROR(WriteImages(
          s, o.bits,
          [&](int i) {
            char name[32];
            std::snprintf(name, sizeof name, "img_%03d%s", i, ext.c_str());
            return (d / name).string();
          },
          progress));
      if (s.has_mask()) MATFIT_RETURN_IF_ERROR(WriteMask(s, (d / "mask.png").string()));
      return WriteFileAtomic((d / "lights.lp").string(), lp);
    }
    case Layout::kDiligent: {
      std::string names, dirs, ints;
      for (int i = 0; i < n; ++i) {
        char name[32];
        std::snprintf(name, sizeof name, "%03d%s", i + 1, ext.c_str());
        names += std::string(name) + "\n";
        const LightSample& l = s.lights()[i];
        dirs += Num(l.direction.x) + " " + Num(l.direction.y) + " " + Num(l.direction.z) + "\n";
        ints += Num(l.intensity.x) + " " + Num(l.intensity.y) + " " + Num(l.intensity.z) + "\n";
      }
      MATFIT_RETURN_IF_ERROR(WriteImages(
          s, o.bits,
          [&](int i) {
            char name[32];
            std::snprintf(name, sizeof name, "%03d%s", i + 1, ext.c_str());
            return (d / name).string();
          },
          progress));
      MATFIT_RETURN_IF_ERROR(WriteMask(s, (d / "mask.png").string()));
      MATFIT_RETURN_IF_ERROR(WriteFileAtomic((d / "filenames.txt").string(), names));
      MATFIT_RETURN_IF_ERROR(WriteFileAtomic((d / "light_directions.txt").string(), dirs));
      return WriteFileAtomic((d / "light_intensities.txt").string(), ints);
    }
    case Layout::kLightsTxt: {
      std::string txt = std::to_string(n) + "\n";
      for (int i = 0; i < n; ++i) {
        const Vec3& l = s.lights()[i].direction;
        txt += Num(l.x) + " " + Num(l.y) + " " + Num(l.z) + "\n";
      }
      MATFIT_RETURN_IF_ERROR(WriteImages(
          s, o.bits,
          [&](int i) { return (d / (o.object_name + "." + std::to_string(i) + ext)).string(); },
          progress));
      if (s.has_mask())
        MATFIT_RETURN_IF_ERROR(WriteMask(s, (d / (o.object_name + ".mask.png")).string()));
      return WriteFileAtomic((d / "lights.txt").string(), txt);
    }
    case Layout::kAuto: break;
  }
  return InvalidArgument("no writer for this layout");
}

}  // namespace matfit
