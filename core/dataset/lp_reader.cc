// RTI `.lp` light files: first line N, then N lines "file lx ly lz" (paths relative to the
// .lp file; file names may contain spaces, the last three tokens are the direction).
// An optional mask.png beside the .lp file is read as the sample mask.
#include <filesystem>

#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"
#include "core/text_file.h"

namespace matfit {
namespace {
namespace fs = std::filesystem;
}

StatusOr<LightStack> ReadLp(const std::string& path, const ReadOptions& o) {
  auto lines = ReadTextLines(path, o.confine_to);  // confined like every dataset file
  if (!lines.ok()) return lines.status();
  if (lines->empty()) return DataError("'" + path + "' is empty; expected a light count on line 1");
  const TextLine& header = lines->front();
  int count = 0;
  if (header.tokens.size() != 1 || !ParseInt(header.tokens[0], &count) || count <= 0)
    return DataError(AtLine(path, header.number,
                            "expected the number of lights (a positive "
                            "integer) alone on the first line, found '" +
                                header.text + "'"));
  const int entries = int(lines->size()) - 1;
  if (entries != count)
    return DataError("'" + path + "': the first line says " + std::to_string(count) +
                     " lights but " + std::to_string(entries) +
                     " light lines follow; fix the count or the list");
  const fs::path base = fs::path(path).parent_path();
  std::vector<std::string> files;
  std::vector<LightSample> lights;
  for (size_t i = 1; i < lines->size(); ++i) {
    const TextLine& l = (*lines)[i];
    if (l.tokens.size() < 4)
      return DataError(AtLine(path, l.number, "expected 'file lx ly lz', found '" + l.text + "'"));
    const size_t k = l.tokens.size();
    Vec3 d;
    if (!ParseFiniteDouble(l.tokens[k - 3], &d.x) || !ParseFiniteDouble(l.tokens[k - 2], &d.y) ||
        !ParseFiniteDouble(l.tokens[k - 1], &d.z))
      return DataError(AtLine(path, l.number,
                              "light direction '" + l.tokens[k - 3] + " " + l.tokens[k - 2] + " " +
                                  l.tokens[k - 1] + "' is not three finite numbers"));
    auto light = MakeLight(d, path + ":" + std::to_string(l.number));
    if (!light.ok()) return light.status();
    // File name: everything before the direction (may contain spaces).
    std::string name = l.tokens[0];
    for (size_t t = 1; t + 3 < k; ++t) name += " " + l.tokens[t];
    fs::path file = fs::path(name).is_absolute() ? fs::path(name) : base / name;
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) {
      // Files written on another machine often carry its absolute path: try the base name.
      const fs::path local = base / fs::path(name).filename();
      if (fs::is_regular_file(local, ec))
        file = local;
      else
        return NotFound(AtLine(
            path, l.number, "image '" + name + "' not found (looked for '" + file.string() + "')"));
    }
    files.push_back(file.string());
    lights.push_back(*light);
  }
  ImageReadOptions io;
  io.color_space = o.color_space;
  io.confine_to = o.confine_to;
  auto stack = LoadStack(files, std::move(lights), io, o);
  if (!stack.ok()) return stack.status();
  // Optional mask beside the light file (written by `matfit synth`; white = sample).
  const fs::path mask = base / "mask.png";
  std::error_code ec;
  if (fs::is_regular_file(mask, ec)) {
    auto m = ReadMaskImage(mask.string(), stack->width(), stack->full_height(), o);
    if (!m.ok()) return m.status();
    stack->mask = std::move(*m);
  }
  stack->layout = LayoutName(Layout::kLp);
  stack->source = path;
  stack->object_name = FolderName(fs::absolute(path).parent_path().string());
  return stack;
}

}  // namespace matfit
