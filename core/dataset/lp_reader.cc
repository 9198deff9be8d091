// RTI `.lp` light files: first line N, then N lines "file lx ly lz" (paths relative to the
// .lp file; file names may contain spaces, the last three tokens are the direction).
// An optional mask.png beside the .lp file is read as the sample mask.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"
#include "core/path_util.h"
#include "core/text_file.h"
#include "core/warnings.h"

namespace matfit {
namespace {
namespace fs = std::filesystem;

// A Windows absolute path: a drive ("C:\\..", "C:/..") or UNC ("\\\\host\\share") prefix.
bool IsWindowsAbsolute(const std::string& p) {
  const bool drive = p.size() >= 3 && std::isalpha(static_cast<unsigned char>(p[0])) &&
                     p[1] == ':' && (p[2] == '\\' || p[2] == '/');
  return drive || p.rfind("\\\\", 0) == 0;
}

// The name with backslashes read as separators (relative Windows paths: "exports\\img.jpg").
std::string Slashed(std::string p) {
  std::replace(p.begin(), p.end(), '\\', '/');
  return p;
}

// Whether `p` lies inside `root` by name (`..` resolved lexically; links are judged when the
// file is opened, by ResolveInDataset).
bool LexicallyInside(const fs::path& p, const std::string& root) {
  const fs::path a = fs::absolute(p).lexically_normal(), r = fs::absolute(root).lexically_normal();
  auto ai = a.begin();
  for (auto ri = r.begin(); ri != r.end(); ++ri, ++ai) {
    if (ri->empty()) continue;  // a trailing separator
    if (ai == a.end() || *ai != *ri) return false;
  }
  return true;
}

}  // namespace

bool IsForeignPath(const std::string& name) {
  return IsWindowsAbsolute(name) || fs::path(Slashed(name)).is_absolute();
}

std::string ForeignBaseName(const std::string& name) {
  const size_t cut = name.find_last_of(IsWindowsAbsolute(name) ? "/\\:" : "/\\");
  return cut == std::string::npos ? name : name.substr(cut + 1);
}

bool LpNameInside(const std::string& name, const fs::path& base, const std::string& confine_to) {
  if (IsForeignPath(name)) return false;
  return confine_to.empty() || LexicallyInside(base / Slashed(name), confine_to);
}

std::string ResolveLpImage(const std::string& name, const fs::path& base,
                           const std::string& confine_to, bool* by_base_name) {
  std::error_code ec;
  *by_base_name = false;
  // As written: a relative name beside the .lp file (backslashes as separators), an absolute
  // POSIX path only for the CLI. A confined (server) dataset never probes a name outside it.
  if (!IsWindowsAbsolute(name)) {
    const std::string rel = Slashed(name);
    const fs::path as_written = fs::path(rel).is_absolute() ? fs::path(rel) : base / rel;
    const bool allowed = confine_to.empty() || LpNameInside(name, base, confine_to);
    if (allowed && fs::is_regular_file(as_written, ec)) return as_written.string();
  }
  // Files from another machine (absolute, Windows, or a sub-folder that is not here): the base
  // name beside the .lp file, as RTIBuilder users copy the images.
  const std::string leaf = ForeignBaseName(name);
  if (leaf.empty() || leaf == "." || leaf == "..") return {};
  const fs::path local = base / leaf;
  if (!fs::is_regular_file(local, ec)) return {};
  *by_base_name = true;
  return local.string();
}

StatusOr<LightStack> ReadLp(const std::string& path, const ReadOptions& o) {
  auto lines = ReadTextLines(path, o.confine_to);  // confined like every dataset file
  if (!lines.ok()) return lines.status();
  if (lines->empty()) return DataError("'" + path + "' is empty; expected a light count on line 1");
  const TextLine& header = lines->front();
  int count = 0;
  // "N views": every line also gives its image's camera direction (a multi-view set).
  const bool with_views = header.tokens.size() == 2 && header.tokens[1] == "views";
  if ((header.tokens.size() != 1 && !with_views) || !ParseInt(header.tokens[0], &count) ||
      count <= 0)
    return DataError(AtLine(path, header.number,
                            "expected the number of lights (a positive integer) on the first "
                            "line, alone or followed by 'views', found '" +
                                header.text + "'"));
  if (!with_views && o.all_views)
    return InvalidArgument("--view all: '" + DatasetRelative(path, o.confine_to) +
                           "' gives no view per image (its first line is not 'N views'); drop "
                           "--view all");
  const int entries = int(lines->size()) - 1;
  if (entries != count)
    return DataError("'" + path + "': the first line says " + std::to_string(count) +
                     " lights but " + std::to_string(entries) +
                     " light lines follow; fix the count or the list");
  const fs::path base = fs::path(path).parent_path();
  std::vector<std::string> files;
  std::vector<LightSample> lights;
  int fallbacks = 0;
  std::string first_fallback;
  for (size_t i = 1; i < lines->size(); ++i) {
    const TextLine& l = (*lines)[i];
    const size_t numbers = with_views ? 6 : 3;
    if (l.tokens.size() < numbers + 1)
      return DataError(AtLine(path, l.number,
                              std::string("expected 'file lx ly lz") +
                                  (with_views ? " vx vy vz'" : "'") + ", found '" + l.text + "'"));
    // The light's three numbers end the line, or precede the view's three.
    const size_t k = l.tokens.size() - (with_views ? 3 : 0);
    Vec3 d;
    if (!ParseFiniteDouble(l.tokens[k - 3], &d.x) || !ParseFiniteDouble(l.tokens[k - 2], &d.y) ||
        !ParseFiniteDouble(l.tokens[k - 1], &d.z))
      return DataError(AtLine(path, l.number,
                              "light direction '" + l.tokens[k - 3] + " " + l.tokens[k - 2] + " " +
                                  l.tokens[k - 1] + "' is not three finite numbers"));
    auto light = MakeLight(d, path + ":" + std::to_string(l.number));
    if (!light.ok()) return light.status();
    if (with_views) {
      const size_t e = l.tokens.size();
      Vec3 v;
      if (!ParseFiniteDouble(l.tokens[e - 3], &v.x) || !ParseFiniteDouble(l.tokens[e - 2], &v.y) ||
          !ParseFiniteDouble(l.tokens[e - 1], &v.z) || !(v.z > 1e-6) || !(Length(v) > 1e-6))
        return DataError(AtLine(path, l.number,
                                "view direction '" + l.tokens[e - 3] + " " + l.tokens[e - 2] + " " +
                                    l.tokens[e - 1] +
                                    "' is not three finite numbers with z > 0 (the camera above "
                                    "the surface, z toward it)"));
      light->has_view = true;
      light->view = Normalize(v);
      AnglesDegFromDirection(light->view, &light->view_theta_deg, &light->view_phi_deg);
    }
    // File name: everything before the direction (may contain spaces).
    std::string name = l.tokens[0];
    for (size_t t = 1; t + 3 < k; ++t) name += " " + l.tokens[t];
    bool by_base_name = false;
    const std::string file = ResolveLpImage(name, base, o.confine_to, &by_base_name);
    if (file.empty()) {
      const std::string leaf = ForeignBaseName(name);
      auto shown = [&](const fs::path& p) { return DatasetRelative(p.string(), o.confine_to); };
      return NotFound(AtLine(
          shown(path), l.number,
          "image '" + name + "' not found" +
              (LpNameInside(name, base, o.confine_to) ? " as '" + shown(base / Slashed(name)) + "'"
                                                      : "") +
              (leaf != name ? " nor as '" + shown(base / leaf) + "'" : "") +
              "; put the image beside the .lp file or fix its path"));
    }
    if (by_base_name && ++fallbacks == 1) first_fallback = name;
    files.push_back(file);
    lights.push_back(*light);
  }
  // A multi-view set: every view (--view all), the one asked for, or the most frontal.
  Vec3 reference(0, 0, 1);
  if (with_views) {
    std::vector<Vec3> views;  // distinct, in order of first appearance
    for (const LightSample& l : lights)
      if (std::none_of(views.begin(), views.end(),
                       [&](const Vec3& v) { return Length(v - l.view) <= 1e-9; }))
        views.push_back(l.view);
    reference = views[0];
    for (const Vec3& v : views)
      if (v.z > reference.z) reference = v;
    if (o.view) {
      const Vec3 want = DirectionFromAnglesDeg(o.view->theta_deg, o.view->phi_deg);
      // The nearest view (two cameras may lie within 0.5° of each other), if within 0.5°.
      auto it = std::max_element(views.begin(), views.end(), [&](const Vec3& a, const Vec3& b) {
        return Dot(a, want) < Dot(b, want);
      });
      if (Dot(*it, want) < std::cos(0.5 * M_PI / 180)) {
        std::string avail;
        for (size_t v = 0; v < views.size() && v < 12; ++v) {
          double t = 0, p = 0;
          AnglesDegFromDirection(views[v], &t, &p);
          char s[40];
          std::snprintf(s, sizeof s, "%s%.4g,%.4g", v ? ", " : "", t, p);
          avail += s;
        }
        return InvalidArgument(
            "view " + std::to_string(o.view->theta_deg) + "," + std::to_string(o.view->phi_deg) +
            " is not within 0.5° of a view of '" + DatasetRelative(path, o.confine_to) +
            "'; its views (θ,φ): " + avail + (views.size() > 12 ? ", ..." : ""));
      }
      reference = *it;
    }
    if (!o.all_views) {  // one view: its images, as a single-view stack seen from it
      std::vector<std::string> kept_files;
      std::vector<LightSample> kept;
      for (size_t i = 0; i < lights.size(); ++i)
        if (Length(lights[i].view - reference) <= 1e-9) {
          LightSample l = lights[i];
          l.has_view = false;
          kept.push_back(l), kept_files.push_back(files[i]);
        }
      files = std::move(kept_files), lights = std::move(kept);
    }
  }
  ImageReadOptions io;
  io.color_space = o.color_space;
  io.confine_to = o.confine_to;
  auto stack = LoadStack(files, std::move(lights), io, o);
  if (!stack.ok()) return stack.status();
  if (fallbacks > 0)
    stack->read_warnings.push_back(
        Warning(WarningCode::kLpPathFallback,
                std::to_string(fallbacks) + " of " + std::to_string(count) + " image paths in '" +
                    DatasetRelative(path, o.confine_to) +
                    "' are absolute or from another machine (first: '" + first_fallback +
                    "'); the files of those names beside the .lp file were read"));
  // Optional mask beside the light file (written by `matfit synth`; white = sample).
  const fs::path mask = base / "mask.png";
  std::error_code ec;
  if (fs::is_regular_file(mask, ec)) {
    MATFIT_RETURN_IF_ERROR(ApplyMaskFile(mask.string(), o, &*stack));
  }
  if (with_views) {
    stack->view_direction = reference;
    AnglesDegFromDirection(reference, &stack->view_theta_deg, &stack->view_phi_deg);
  }
  stack->layout = LayoutName(Layout::kLp);
  stack->source = path;
  stack->object_name = FolderName(fs::absolute(path).parent_path().string());
  return stack;
}

}  // namespace matfit
