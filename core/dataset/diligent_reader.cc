// DiLiGenT layout: filenames.txt, light_directions.txt (x y z per line), light_intensities.txt
// (r g b per line), mask.png. Images are 16-bit linear PNGs; directions are in camera space
// with x right, y up, z toward the camera, the same frame as ours.
#include <filesystem>

#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"
#include "core/text_file.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

// Reads `path` as rows of three finite numbers.
StatusOr<std::vector<Vec3>> ReadTriples(const std::string& path, const char* what,
                                        const std::string& confine_to) {
  auto lines = ReadTextLines(path, confine_to);
  if (!lines.ok()) return lines.status();
  std::vector<Vec3> rows;
  for (const TextLine& l : *lines) {
    Vec3 v;
    if (l.tokens.size() != 3 || !ParseFiniteDouble(l.tokens[0], &v.x) ||
        !ParseFiniteDouble(l.tokens[1], &v.y) || !ParseFiniteDouble(l.tokens[2], &v.z))
      return DataError(AtLine(
          path, l.number,
          std::string("expected three finite numbers (") + what + "), found '" + l.text + "'"));
    rows.push_back(v);
  }
  return rows;
}

}  // namespace

StatusOr<LightStack> ReadDiligent(const std::string& dir, const ReadOptions& o) {
  const fs::path d(dir);
  const std::string names_path = (d / "filenames.txt").string();
  const std::string dirs_path = (d / "light_directions.txt").string();
  const std::string ints_path = (d / "light_intensities.txt").string();
  auto names = ReadTextLines(names_path, o.confine_to);
  if (!names.ok()) return names.status();
  auto dirs = ReadTriples(dirs_path, "light direction x y z", o.confine_to);
  if (!dirs.ok()) return dirs.status();
  auto ints = ReadTriples(ints_path, "light intensity r g b", o.confine_to);
  if (!ints.ok()) return ints.status();
  const size_t n = names->size();
  if (n == 0) return DataError("'" + names_path + "' lists no images");
  if (dirs->size() != n)
    return DataError("'" + dirs_path + "' has " + std::to_string(dirs->size()) +
                     " directions but '" + names_path + "' lists " + std::to_string(n) +
                     " images; each image needs one line");
  if (ints->size() != n)
    return DataError("'" + ints_path + "' has " + std::to_string(ints->size()) +
                     " intensities but '" + names_path + "' lists " + std::to_string(n) +
                     " images");
  std::vector<std::string> files;
  std::vector<LightSample> lights;
  for (size_t i = 0; i < n; ++i) {
    const TextLine& l = (*names)[i];
    const fs::path f = d / l.text;
    std::error_code ec;
    if (!fs::is_regular_file(f, ec))
      return NotFound(
          AtLine(names_path, l.number, "image '" + l.text + "' not found in '" + dir + "'"));
    auto light = MakeLight((*dirs)[i], dirs_path + ":" + std::to_string(i + 1));
    if (!light.ok()) return light.status();
    const Vec3 e = (*ints)[i];
    if (!(e.x > 0 && e.y > 0 && e.z > 0))
      return DataError(ints_path + ":" + std::to_string(i + 1) + ": light intensities must be > 0");
    light->intensity = e;
    files.push_back(f.string());
    lights.push_back(*light);
  }
  ImageReadOptions io;
  io.color_space = o.color_space;
  io.confine_to = o.confine_to;
  io.layout_default = ColorSpaceChoice::kLinear;  // DiLiGenT images are linear 16-bit
  auto stack = LoadStack(files, std::move(lights), io, o);
  if (!stack.ok()) return stack.status();
  const fs::path mask = d / "mask.png";
  std::error_code ec;
  if (fs::exists(mask, ec)) {
    MATFIT_RETURN_IF_ERROR(ApplyMaskFile(mask.string(), o, &*stack));
  }
  stack->layout = LayoutName(Layout::kDiligent);
  stack->source = dir;
  stack->object_name = FolderName(dir);
  return stack;
}

}  // namespace matfit
