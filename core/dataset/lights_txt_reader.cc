// `lights.txt` + numbered images (UW psm sets): lights.txt (first line N, then N lines
// "x y z") in the folder or its parent; images NAME.0.ext ... NAME.(N-1).ext with NAME the
// folder name; optional NAME.mask.ext.
#include <filesystem>

#include "core/dataset/btf_names.h"
#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"
#include "core/path_util.h"
#include "core/text_file.h"
#include "core/warnings.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

// NAME.<index> with any image extension, or empty.
std::string FindNumbered(const fs::path& dir, const std::string& stem) {
  std::error_code ec;
  for (const char* ext : {".tga", ".png", ".jpg", ".tif", ".tiff", ".exr", ".bmp", ".jpeg"}) {
    const fs::path p = dir / (stem + ext);
    if (fs::is_regular_file(p, ec)) return p.string();
  }
  return {};
}

}  // namespace

std::string FindLightsTxt(const std::string& dir, const std::string& confine_to) {
  std::error_code ec;
  const fs::path here = fs::path(dir) / "lights.txt";
  if (fs::is_regular_file(here, ec)) return here.string();  // a link is judged when opened
  const fs::path parent = fs::path(dir).parent_path();
  if (!confine_to.empty() && !PathWithin(parent.string(), confine_to)) return {};
  return fs::is_regular_file(parent / "lights.txt", ec) ? (parent / "lights.txt").string()
                                                        : std::string();
}

bool ParentHasLightsTxt(const std::string& dir) {
  std::error_code ec;
  return fs::is_regular_file(fs::path(dir).parent_path() / "lights.txt", ec);
}

StatusOr<LightStack> ReadLightsTxt(const std::string& dir_in, const ReadOptions& o) {
  std::string dir = dir_in;
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const std::string lights_path = FindLightsTxt(dir, o.confine_to);
  if (lights_path.empty() && !o.confine_to.empty() && ParentHasLightsTxt(dir))
    return NotFound(
        "no lights.txt in the dataset folder; the lights.txt in its parent folder lies outside "
        "the dataset folder and is not read: copy it into the dataset folder");
  if (lights_path.empty()) return NotFound("no lights.txt in '" + dir + "' or its parent folder");
  auto lines = ReadTextLines(lights_path, o.confine_to);
  if (!lines.ok()) return lines.status();
  if (lines->empty()) return DataError("'" + lights_path + "' is empty; expected a light count");
  int count = 0;
  const TextLine& header = lines->front();
  if (header.tokens.size() != 1 || !ParseInt(header.tokens[0], &count) || count <= 0)
    return DataError(AtLine(
        lights_path, header.number,
        "expected the number of lights alone on the first line, found '" + header.text + "'"));
  if (int(lines->size()) - 1 != count)
    return DataError("'" + lights_path + "': the first line says " + std::to_string(count) +
                     " lights but " + std::to_string(lines->size() - 1) +
                     " direction lines follow");
  const std::string name = fs::path(dir).filename().string();
  std::vector<std::string> files;
  std::vector<LightSample> lights;
  for (int i = 0; i < count; ++i) {
    const TextLine& l = (*lines)[i + 1];
    Vec3 d;
    if (l.tokens.size() != 3 || !ParseFiniteDouble(l.tokens[0], &d.x) ||
        !ParseFiniteDouble(l.tokens[1], &d.y) || !ParseFiniteDouble(l.tokens[2], &d.z))
      return DataError(AtLine(lights_path, l.number,
                              "expected three finite numbers 'x y z', found '" + l.text + "'"));
    auto light = MakeLight(d, lights_path + ":" + std::to_string(l.number));
    if (!light.ok()) return light.status();
    const std::string file = FindNumbered(dir, name + "." + std::to_string(i));
    if (file.empty())
      return NotFound("image " + std::to_string(i) + " of '" + lights_path +
                      "' not found: expected '" +
                      (fs::path(dir) / (name + "." + std::to_string(i))).string() +
                      ".tga' (or .png, .jpg, ...)");
    files.push_back(file);
    lights.push_back(*light);
  }
  ImageReadOptions io;
  io.color_space = o.color_space;
  io.confine_to = o.confine_to;
  auto stack = LoadStack(files, std::move(lights), io, o);
  if (!stack.ok()) return stack.status();
  const std::string mask = FindNumbered(dir, name + ".mask");
  if (!mask.empty()) {
    auto m = ReadMaskImage(mask, stack->width(), stack->full_height(), o);
    if (!m.ok()) return m.status();
    stack->mask = std::move(*m);
  }
  // Numbered images beyond the light count are a miscounted lights.txt, not spare files.
  int extra = 0;
  while (extra < 100000 && !FindNumbered(dir, name + "." + std::to_string(count + extra)).empty())
    ++extra;
  if (extra > 0)
    stack->read_warnings.push_back(Warning(
        WarningCode::kLightCountMismatch,
        "'" + DatasetRelative(lights_path, o.confine_to) + "' lists " + std::to_string(count) +
            " lights but the folder also has " + std::to_string(extra) +
            " more numbered image(s) (" + name + "." + std::to_string(count) + ".*" +
            (extra > 1 ? " to " + name + "." + std::to_string(count + extra - 1) + ".*" : "") +
            "), which are not used; give every image its light in lights.txt"));
  stack->layout = LayoutName(Layout::kLightsTxt);
  stack->source = dir;
  stack->object_name = name;
  return stack;
}

}  // namespace matfit
