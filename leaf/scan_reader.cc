#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"
#include "core/image_io.h"
#include "core/path_util.h"
#include "leaf/scan.h"

namespace matfit::leaf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

bool WildcardMatch(const std::string& pat, const std::string& s) {
  // '*' matches any run, '?' one character; case-sensitive.
  size_t p = 0, i = 0, star = std::string::npos, mark = 0;
  while (i < s.size()) {
    if (p < pat.size() && (pat[p] == '?' || pat[p] == s[i])) {
      ++p, ++i;
    } else if (p < pat.size() && pat[p] == '*') {
      star = p++, mark = i;
    } else if (star != std::string::npos) {
      p = star + 1, i = ++mark;
    } else {
      return false;
    }
  }
  while (p < pat.size() && pat[p] == '*') ++p;
  return p == pat.size();
}

bool IsImageName(const std::string& name) {
  std::string ext = fs::path(name).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" ||
         ext == ".exr" || ext == ".tga";
}

// Files of `dir` matching the pattern, in natural order (2 before 10).
std::vector<std::string> Glob(const std::string& dir, const std::string& pat) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file(ec) && IsImageName(e.path().filename().string()) &&
        WildcardMatch(pat, e.path().filename().string()))
      out.push_back(e.path().filename().string());
  auto key = [](const std::string& s) {
    size_t i = 0;
    while (i < s.size() && !std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
    long n = 0;
    for (size_t j = i; j < s.size() && std::isdigit(static_cast<unsigned char>(s[j])); ++j)
      n = n * 10 + (s[j] - '0');
    return std::make_pair(n, s);
  };
  std::sort(out.begin(), out.end(), [&](const auto& a, const auto& b) { return key(a) < key(b); });
  return out;
}

std::string Num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

Status ReadOne(const std::string& path, ColorSpaceChoice cs, const std::string& confine,
               const std::optional<CropRect>& crop, Image* out) {
  ImageReadOptions o;
  o.color_space = cs;
  o.confine_to = confine;
  if (crop) o.col0 = crop->x, o.cols = crop->w, o.row0 = crop->y, o.rows = crop->h;
  auto img = ReadImage(path, o);
  if (!img.ok()) return img.status();
  *out = std::move(*img);
  return Status::Ok();
}

}  // namespace

StatusOr<LeafScan> ReadLeafScan(const std::string& dir, const std::string& manifest, bool confine) {
  LeafScanReadOptions o;
  o.manifest = manifest;
  o.confine = confine;
  return ReadLeafScan(dir, o);
}

StatusOr<LeafScan> ReadLeafScan(const std::string& dir, const LeafScanReadOptions& options) {
  const std::string& manifest_arg = options.manifest;
  const std::string confine_to = options.confine ? dir : std::string();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return NotFound("leaf scan folder '" + dir + "' does not exist or is not a folder");
  LeafScan scan;
  scan.source = dir;
  std::string manifest = manifest_arg;
  if (manifest.empty() && fs::exists(fs::path(dir) / "leaf.json", ec))
    manifest = (fs::path(dir) / "leaf.json").string();

  json m = json::object();
  if (!manifest.empty()) {
    auto real = ResolveInDataset(manifest, confine_to);  // the sandbox, as for every file
    if (!real.ok()) return Status(real.status().code(), "leaf manifest " + real.status().message());
    std::ifstream in(*real);
    if (!in) return NotFound("cannot open leaf manifest '" + manifest + "'");
    std::stringstream text;
    text << in.rdbuf();
    m = json::parse(text.str(), nullptr, false);
    if (m.is_discarded() || !m.is_object())
      return DataError("leaf manifest '" + manifest + "' is not a JSON object");
  }
  auto field_error = [&](const std::string& f, const std::string& why) {
    return DataError("leaf manifest '" + manifest + "': field '" + f + "' " + why);
  };
  auto get_string = [&](const char* f, std::string* out) -> Status {
    if (!m.contains(f)) return Status::Ok();
    if (!m[f].is_string()) return field_error(f, "must be a string (a file name)");
    *out = m[f].get<std::string>();
    return Status::Ok();
  };
  auto get_number = [&](const char* f, double lo, double hi, double* out) -> Status {
    if (!m.contains(f)) return Status::Ok();
    if (!m[f].is_number() || !(m[f].get<double>() >= lo && m[f].get<double>() <= hi))
      return field_error(f, "must be a number in [" + Num(lo) + ", " + Num(hi) + "]");
    *out = m[f].get<double>();
    return Status::Ok();
  };
  ColorSpaceChoice cs = ColorSpaceChoice::kAuto;
  if (m.contains("color_space")) {
    if (!m["color_space"].is_string() ||
        !ParseColorSpaceChoice(m["color_space"].get<std::string>(), &cs))
      return field_error("color_space", "must be \"auto\", \"srgb\" or \"linear\"");
  }
  std::string top, front;
  MATFIT_RETURN_IF_ERROR(get_string("top_lit", &top));
  MATFIT_RETURN_IF_ERROR(get_string("front_lit", &front));
  MATFIT_RETURN_IF_ERROR(get_number("mm_per_pixel", 0, 100, &scan.mm_per_pixel));
  MATFIT_RETURN_IF_ERROR(get_number("marker_size_mm", 0, 1000, &scan.marker_size_mm));
  MATFIT_RETURN_IF_ERROR(get_number("max_thickness_mm", 0, 10, &scan.max_thickness_mm));
  MATFIT_RETURN_IF_ERROR(
      get_number("displacement_scale_mm", 1e-9, 1e6, &scan.displacement_scale_mm));

  // Back-lit images: a list, a wildcard pattern, or detection.
  std::vector<std::string> back;
  if (m.contains("back_lit")) {
    const json& b = m["back_lit"];
    if (b.is_string()) {
      back = Glob(dir, b.get<std::string>());
      if (back.empty()) back = {b.get<std::string>()};  // a plain file name
    } else if (b.is_array()) {
      for (const auto& e : b) {
        if (!e.is_string()) return field_error("back_lit", "must list file names (strings)");
        back.push_back(e.get<std::string>());
      }
    } else {
      return field_error("back_lit", "must be a file name, a pattern like \"*_BL.png\" or a list");
    }
  } else {
    back = Glob(dir, "*_BL.*");
    if (back.empty()) back = Glob(dir, "*back*");
  }
  if (back.empty())
    return DataError("leaf scan '" + dir +
                     "' has no back-lit images: name them *_BL.png (or *back*.png), or list them "
                     "in the manifest's \"back_lit\" field");
  // Top-lit stack: the manifest's .lp file, or the folder's only .lp file.
  if (top.empty() && front.empty() && !m.contains("top_lit")) {
    std::vector<std::string> lps;
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().extension() == ".lp") lps.push_back(e.path().filename().string());
    if (lps.size() == 1) top = lps[0];
    if (lps.size() > 1)
      return DataError("leaf scan '" + dir +
                       "' has several .lp files; name the top-lit one in "
                       "the manifest's \"top_lit\" field");
    if (lps.empty()) {
      auto f = Glob(dir, "*_FL.*");
      if (f.empty()) f = Glob(dir, "*front*");
      if (!f.empty()) front = f[0];
    }
  }
  if (top.empty() && front.empty())
    return DataError("leaf scan '" + dir +
                     "' has neither top-lit images (a .lp file) nor a front-lit photo (*_FL.png "
                     "or *front*.png); add one, or name it in the manifest");

  auto in_dir = [&](const std::string& f) { return (fs::path(dir) / f).string(); };
  // Headers first: every file confined and the whole scan within the sample budget before a
  // pixel is decoded.
  {
    int64_t samples = 0, images = 0;
    if (!top.empty()) {
      ReadOptions ro;
      ro.layout = Layout::kLp;
      ro.confine_to = confine_to;
      ro.headers_only = true;
      ro.crop = options.crop;
      auto st = ReadLp(in_dir(top), ro);
      if (!st.ok()) return st.status();
      images += int64_t(st->lights().size());
      samples += int64_t(st->lights().size()) * st->width() * st->height() * st->channels();
    }
    std::vector<std::string> singles = back;
    if (top.empty()) singles.push_back(front);
    for (const char* field : {"upper_albedo", "lower_albedo", "upper_normal", "lower_normal",
                              "upper_displacement", "lower_displacement"}) {
      std::string f;
      MATFIT_RETURN_IF_ERROR(get_string(field, &f));
      if (!f.empty()) singles.push_back(f);
    }
    ImageReadOptions io;
    io.confine_to = confine_to;
    for (const auto& f : singles) {
      auto hd = ReadImageHeader(in_dir(f), io);
      if (!hd.ok()) return hd.status();
      ++images;
      if (options.crop) {
        MATFIT_RETURN_IF_ERROR(CheckCrop(*options.crop, hd->width, hd->height, f));
        hd->width = options.crop->w, hd->height = options.crop->h;
      }
      samples += int64_t(hd->width) * hd->height * hd->channels;
    }
    if (options.max_samples > 0 && samples > options.max_samples)
      return DataError("the leaf scan's " + std::to_string(images) + " images hold " +
                       std::to_string(samples) +
                       " samples (images × width × height × channels), more than the limit of " +
                       std::to_string(options.max_samples) +
                       "; crop or downscale the scan, or send fewer images");
    if (options.headers_only) return scan;
  }
  if (!top.empty()) {
    ReadOptions ro;
    ro.layout = Layout::kLp;
    ro.color_space = cs;
    ro.confine_to = confine_to;
    ro.crop = options.crop;
    auto st = ReadLp(in_dir(top), ro);
    if (!st.ok()) return st.status();
    scan.top = std::move(*st);
  } else {
    MATFIT_RETURN_IF_ERROR(ReadOne(in_dir(front), cs, confine_to, options.crop, &scan.front));
    scan.front_file = front;
  }
  for (const auto& f : back) {
    Image img;
    MATFIT_RETURN_IF_ERROR(ReadOne(in_dir(f), cs, confine_to, options.crop, &img));
    scan.back.push_back(std::move(img));
    scan.back_files.push_back(f);
  }
  const int w = scan.back[0].width(), h = scan.back[0].height();
  auto check_grid = [&](const Image& img, const std::string& what) -> Status {
    if (!img.empty() && (img.width() != w || img.height() != h))
      return DataError("leaf scan '" + dir + "': " + what + " is " + std::to_string(img.width()) +
                       "x" + std::to_string(img.height()) + " but the back-lit images are " +
                       std::to_string(w) + "x" + std::to_string(h) +
                       "; every image of a scan must share one pixel grid");
    return Status::Ok();
  };
  for (size_t i = 0; i < scan.back.size(); ++i)
    MATFIT_RETURN_IF_ERROR(check_grid(scan.back[i], "back-lit image '" + back[i] + "'"));
  if (!scan.top.image_files.empty() && (scan.top.width() != w || scan.top.height() != h))
    return DataError("leaf scan '" + dir + "': the top-lit images are " +
                     std::to_string(scan.top.width()) + "x" + std::to_string(scan.top.height()) +
                     " but the back-lit images are " + std::to_string(w) + "x" + std::to_string(h) +
                     "; every image of a scan must share one pixel grid");
  MATFIT_RETURN_IF_ERROR(check_grid(scan.front, "front-lit photo '" + front + "'"));
  // Optional scans.
  const std::pair<const char*, Image*> opt[] = {{"upper_albedo", &scan.upper_albedo},
                                                {"lower_albedo", &scan.lower_albedo},
                                                {"upper_normal", &scan.upper_normal},
                                                {"lower_normal", &scan.lower_normal},
                                                {"upper_displacement", &scan.upper_displacement},
                                                {"lower_displacement", &scan.lower_displacement}};
  for (const auto& [field, img] : opt) {
    std::string f;
    MATFIT_RETURN_IF_ERROR(get_string(field, &f));
    if (f.empty()) continue;
    const std::string sf(field);
    const bool albedo = sf.find("albedo") != std::string::npos;
    const bool normal = sf.find("normal") != std::string::npos;
    MATFIT_RETURN_IF_ERROR(
        ReadOne(in_dir(f), albedo ? cs : ColorSpaceChoice::kLinear, confine_to, options.crop, img));
    MATFIT_RETURN_IF_ERROR(check_grid(*img, "'" + sf + "' (" + f + ")"));
    if (normal && img->channels() < 3)
      return DataError("leaf scan '" + dir + "': '" + sf + "' (" + f +
                       ") has 1 channel; a normal map needs rgb = n*0.5+0.5");
    if (albedo && img->channels() == 1) {  // grey albedo photo → the same value in r, g, b
      Image rgb(img->width(), img->height(), 3);
      for (int c = 0; c < 3; ++c)
        std::copy(img->Plane(0).begin(), img->Plane(0).end(), rgb.Plane(c).begin());
      *img = std::move(rgb);
    }
    if (!albedo && !normal && img->channels() > 1) {  // displacement: first channel
      Image one(img->width(), img->height(), 1);
      std::copy(img->Plane(0).begin(), img->Plane(0).end(), one.Plane(0).begin());
      *img = std::move(one);
    }
  }
  return scan;
}

}  // namespace matfit::leaf
