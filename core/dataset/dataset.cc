// Layout names, detection and dispatch.
#include "core/dataset/dataset.h"

#include <algorithm>
#include <filesystem>
#include <utility>
#include <vector>

#include "core/dataset/btf_names.h"
#include "core/dataset/stack_loader.h"
#include "core/near_lights.h"
#include "core/path_util.h"
#include "core/text_file.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

bool AnyMatching(const fs::path& dir, bool (*parse)(const std::string&, BtfName*)) {
  std::error_code ec;
  BtfName a;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.is_regular_file(ec) && parse(e.path().filename().string(), &a)) return true;
    if (e.is_directory(ec))
      for (const auto& f : fs::directory_iterator(e.path(), ec))
        if (f.is_regular_file(ec) && parse(f.path().filename().string(), &a)) return true;
  }
  return false;
}

}  // namespace

const char* LayoutName(Layout layout) {
  switch (layout) {
    case Layout::kAuto: return "auto";
    case Layout::kBonn: return "bonn";
    case Layout::kUtia: return "utia";
    case Layout::kLp: return "lp";
    case Layout::kDiligent: return "diligent";
    case Layout::kLightsTxt: return "lights-txt";
  }
  return "?";
}

std::vector<std::string> LayoutNames() { return {"bonn", "utia", "lp", "diligent", "lights-txt"}; }

bool ParseLayout(const std::string& name, Layout* out) {
  for (Layout l : {Layout::kAuto, Layout::kBonn, Layout::kUtia, Layout::kLp, Layout::kDiligent,
                   Layout::kLightsTxt})
    if (name == LayoutName(l)) {
      *out = l;
      return true;
    }
  if (name == "psm") {  // the UW course sets use lights.txt
    *out = Layout::kLightsTxt;
    return true;
  }
  return false;
}

bool ParseCrop(const std::string& text, CropRect* out) {
  int v[4];
  size_t pos = 0;
  for (int i = 0; i < 4; ++i) {
    const size_t end = i < 3 ? text.find(',', pos) : text.size();
    if (end == std::string::npos || end == pos || end - pos > 9) return false;
    v[i] = 0;
    for (size_t k = pos; k < end; ++k) {
      if (text[k] < '0' || text[k] > '9') return false;
      v[i] = v[i] * 10 + (text[k] - '0');
    }
    pos = end + 1;
  }
  if (v[2] <= 0 || v[3] <= 0) return false;
  *out = CropRect{v[0], v[1], v[2], v[3]};
  return true;
}

bool ReadOptions::Check(std::string* why) const {
  if (crop && (crop->x < 0 || crop->y < 0 || crop->w <= 0 || crop->h <= 0)) {
    *why = "--crop needs x,y ≥ 0 and a width and height > 0, got " + std::to_string(crop->x) + "," +
           std::to_string(crop->y) + "," + std::to_string(crop->w) + "," + std::to_string(crop->h);
    return false;
  }
  if (row0 < 0 || rows < 0) {
    *why = "a band of rows needs row0 ≥ 0 and rows ≥ 0 (0 = all), got " + std::to_string(row0) +
           " and " + std::to_string(rows);
    return false;
  }
  if (max_stack_samples < 0) {
    *why =
        "the stack sample limit must be ≥ 0 (0 = none), got " + std::to_string(max_stack_samples);
    return false;
  }
  if (view && all_views) {
    *why = "--view: give one view θ,φ or 'all', not both";
    return false;
  }
  if (view && !(view->theta_deg >= 0 && view->theta_deg < 90)) {
    *why = "--view: θ must be in [0, 90) degrees, got " + std::to_string(view->theta_deg);
    return false;
  }
  if (view && !(view->phi_deg >= 0 && view->phi_deg < 360)) {
    *why = "--view: φ must be in [0, 360) degrees, got " + std::to_string(view->phi_deg);
    return false;
  }
  return true;
}

StatusOr<Layout> DetectLayout(const std::string& path, std::string* reason,
                              const std::string& confine_to) {
  std::error_code ec;
  const fs::path p(path);
  // Confined (the server): the folder is the client's dataset, not a server path to show.
  const std::string shown = confine_to.empty() ? "'" + path + "'" : "the dataset folder";
  if (!fs::exists(p, ec)) return NotFound("'" + path + "' does not exist");
  if (fs::is_regular_file(p, ec)) {
    if (p.extension() == ".lp") {
      *reason = "a .lp light file";
      return Layout::kLp;
    }
    return InvalidArgument("'" + path +
                           "' is a file but not a .lp light file; pass the dataset "
                           "folder instead");
  }
  if (fs::is_empty(p, ec))
    return DataError((confine_to.empty() ? "dataset folder '" + path + "'" : shown) +
                     " is empty: expected images and a light file");
  // Evidence for each layout; a folder with evidence for two is refused, never guessed.
  std::vector<std::pair<Layout, std::string>> found;
  if (fs::exists(p / "filenames.txt", ec) && fs::exists(p / "light_directions.txt", ec))
    found.push_back({Layout::kDiligent, "filenames.txt and light_directions.txt (DiLiGenT)"});
  std::vector<std::string> lps;
  for (const auto& e : fs::directory_iterator(p, ec))
    if (e.is_regular_file(ec) && e.path().extension() == ".lp") lps.push_back(e.path().filename());
  if (lps.size() > 1) {
    std::sort(lps.begin(), lps.end());
    std::string list;
    for (const auto& s : lps) list += (list.empty() ? "" : ", ") + s;
    return InvalidArgument(shown + " holds several .lp files (" + list +
                           "); keep only the one to read, or pass it, e.g. '" +
                           DatasetRelative((p / lps[0]).string(), confine_to) + "'");
  }
  if (lps.size() == 1) found.push_back({Layout::kLp, "one .lp light file (" + lps[0] + ")"});
  const std::string name = p.filename().string();
  const std::string lights = FindLightsTxt(path, confine_to);
  if (!lights.empty()) {
    // Numbered images NAME.N; else, with lights.txt in the folder itself, images.txt or any
    // image files (the reader orders them by name).
    std::string evidence;
    bool images = false;
    for (const auto& e : fs::directory_iterator(p, ec)) {
      if (e.path().stem() == name + ".0") evidence = "numbered images " + name + ".N";
      images |= e.is_regular_file(ec) && IsImageExtension(e.path().extension().string());
    }
    const bool here = fs::is_regular_file(p / "lights.txt", ec);
    if (evidence.empty() && fs::is_regular_file(p / "images.txt", ec))
      evidence = "the image list images.txt";
    else if (evidence.empty() && here && images)
      evidence = "image files (in light order by name)";
    if (!evidence.empty())
      found.push_back(
          {Layout::kLightsTxt, "'" + DatasetRelative(lights, confine_to) + "' and " + evidence});
  }
  if (AnyMatching(p, ParseBonnName))
    found.push_back(
        {Layout::kBonn, "image names like 'NNNNN tlAAA plBBB tvCCC pvDDD' (Bonn UBO2003)"});
  if (AnyMatching(p, ParseUtiaName))
    found.push_back({Layout::kUtia, "image names like 'tl000_pl000_tv000_pv000' (UTIA)"});
  if (found.size() == 1) {
    *reason = found[0].second;
    return found[0].first;
  }
  if (found.size() > 1) {
    std::string list, choices;
    for (size_t i = 0; i < found.size(); ++i) {
      const std::string sep = i == 0 ? "" : i + 1 == found.size() ? " and " : ", ";
      list += sep + LayoutName(found[i].first) + " (" + found[i].second + ")";
      choices += (i == 0 ? "" : " or ") + std::string("--layout ") + LayoutName(found[i].first);
    }
    return DataError(shown + " holds the files of " + std::to_string(found.size()) +
                     " layouts: " + list + "; pass " + choices +
                     " to say which to read, or remove the other's files");
  }
  const std::string parent_note =
      !confine_to.empty() && ParentHasLightsTxt(path)
          ? " (the lights.txt in the parent folder lies outside the dataset folder and is not "
            "read: copy it into the dataset folder)"
          : "";
  return DataError("cannot tell the layout of " + shown +
                   ": found no filenames.txt (DiLiGenT), no .lp file, no lights.txt with "
                   "images (named " +
                   name + ".0.*, listed in images.txt, or beside it)" + parent_note +
                   ", and no BTF-named images; see docs/formats.md or pass "
                   "--layout");
}

namespace {

// light_positions.txt beside the lights (the folder, or the .lp file's folder): N, then N lines
// x y z in source pixels (docs/formats.md). Sets each light's position and its nominal
// direction (seen from the image centre); absent file: the stack is left as read.
Status ApplyLightPositions(const std::string& path, const ReadOptions& o, LightStack* s) {
  std::error_code ec;
  std::string trimmed = path;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  // Beside the lights: the .lp's folder, the dataset folder, or beside the parent's lights.txt
  // a lights-txt set uses (never above a confined folder).
  fs::path dir =
      fs::is_directory(trimmed, ec) ? fs::path(trimmed) : fs::path(trimmed).parent_path();
  if (s->layout == "lights-txt" && !fs::exists(dir / "lights.txt", ec)) {
    const std::string lights = FindLightsTxt(dir.string(), o.confine_to);
    if (!lights.empty()) dir = fs::path(lights).parent_path();
  }
  const fs::path file = dir / "light_positions.txt";
  if (o.distant_lights || !fs::exists(file, ec)) return Status::Ok();
  auto lines = ReadTextLines(file.string(), o.confine_to);
  if (!lines.ok()) return lines.status();
  const std::string name = o.confine_to.empty() ? file.string() : "light_positions.txt";
  int n = 0;
  if (lines->empty() || lines->front().tokens.size() != 1 ||
      !ParseInt(lines->front().tokens[0], &n))
    return DataError(name + ": the first line must be the number of lights");
  if (n != int(s->lights().size()) || int(lines->size()) != n + 1)
    return DataError(name + ": holds " + std::to_string(int(lines->size()) - 1) +
                     " positions (header " + std::to_string(n) + ") for " +
                     std::to_string(s->lights().size()) +
                     " images; give one position per image, in the images' order");
  for (int i = 0; i < n; ++i) {
    const TextLine& line = (*lines)[size_t(i) + 1];
    double v[3];
    if (line.tokens.size() != 3 || !ParseFiniteDouble(line.tokens[0], &v[0]) ||
        !ParseFiniteDouble(line.tokens[1], &v[1]) || !ParseFiniteDouble(line.tokens[2], &v[2]))
      return DataError(
          AtLine(name, line.number, "expected x y z (source pixels), got '" + line.text + "'"));
    LightSample& l = s->lights()[size_t(i)];
    l.has_position = true, l.position = Vec3(v[0], v[1], v[2]);
  }
  // Texel (x, y) of the images as read sits at pixel (crop_x + x + ½, crop_y + y + ½) of the
  // source images, whose centre is the frame's origin (x right, y up).
  const int W = s->source_width > 0 ? s->source_width : s->width();
  const int H = s->source_height > 0 ? s->source_height : s->full_height();
  s->near_frame = {s->crop_x + 0.5 - 0.5 * W, 0.5 * H - s->crop_y - 0.5 - s->band.row0, 1.0};
  if (Status st = CheckLightPositions(*s); !st.ok()) return DataError(name + ": " + st.message());
  for (LightSample& l : s->lights()) {
    const LightSample seen = LightFromDirection(l.position);
    l.direction = seen.direction, l.theta_deg = seen.theta_deg, l.phi_deg = seen.phi_deg;
  }
  return Status::Ok();
}

StatusOr<LightStack> ReadLayout(const std::string& path, const ReadOptions& options);

}  // namespace

StatusOr<LightStack> ReadDataset(const std::string& path, const ReadOptions& options) {
  auto stack = ReadLayout(path, options);
  if (!stack.ok()) return stack;
  if (Status st = ApplyLightPositions(path, options, &*stack); !st.ok()) return st;
  return stack;
}

namespace {

StatusOr<LightStack> ReadLayout(const std::string& path, const ReadOptions& options) {
  std::string why;
  if (!options.Check(&why)) return InvalidArgument(why);
  Layout layout = options.layout;
  if (layout == Layout::kAuto) {
    auto detected = DetectLayout(path, &why, options.confine_to);
    if (!detected.ok()) return detected.status();
    layout = *detected;
  }
  if (options.all_views && layout != Layout::kBonn && layout != Layout::kUtia &&
      layout != Layout::kLp)
    return InvalidArgument(std::string("--view all reads every view of a BTF (the bonn and utia "
                                       "layouts, or an .lp with a view per image); this dataset "
                                       "is ") +
                           LayoutName(layout) + ", one view: drop --view all");
  std::error_code ec;
  switch (layout) {
    case Layout::kBonn:
    case Layout::kUtia: return ReadBtfFolder(path, layout, options);
    case Layout::kDiligent: return ReadDiligent(path, options);
    case Layout::kLightsTxt: return ReadLightsTxt(path, options);
    case Layout::kLp: {
      if (fs::is_regular_file(path, ec)) return ReadLp(path, options);
      std::vector<std::string> lps;
      for (const auto& e : fs::directory_iterator(path, ec))
        if (e.is_regular_file(ec) && e.path().extension() == ".lp")
          lps.push_back(e.path().string());
      if (lps.size() != 1)
        return DataError("--layout lp: '" + path + "' must contain exactly one .lp file (found " +
                         std::to_string(lps.size()) + "); or pass the .lp file itself");
      return ReadLp(lps[0], options);
    }
    case Layout::kAuto: break;
  }
  return InvalidArgument("no reader for layout");
}

}  // namespace

}  // namespace matfit
