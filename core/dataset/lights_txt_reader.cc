// `lights.txt` sets (the UW psm sets and any folder of images with one): lights.txt (first line
// N, then N lines "x y z") in the folder or its parent. The images, in light order, are
//   1. the files listed in images.txt (one name per line, relative to the folder), when present;
//   2. else NAME.0.ext ... NAME.(N-1).ext with NAME the folder name (optional NAME.mask.ext);
//   3. else every image file of the folder, in natural order ("img2" before "img10"); a file
//      whose name contains "mask" is the mask, not an image.
// The number of images must equal N: a miscounted list is an error, never a silent drop.
#include <algorithm>
#include <cctype>
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
  for (const char* ext : kImageExtensions) {
    const fs::path p = dir / (stem + ext);
    if (fs::is_regular_file(p, ec)) return p.string();
  }
  return {};
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Natural order: runs of digits compare as numbers ("img2" < "img10"), the rest by character.
bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) &&
        std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      size_t is = i, js = j;  // skip leading zeros, then the longer number is larger
      while (is + 1 < ie && a[is] == '0') ++is;
      while (js + 1 < je && b[js] == '0') ++js;
      if (ie - is != je - js) return ie - is < je - js;
      const int c = a.compare(is, ie - is, b, js, je - js);
      if (c != 0) return c < 0;
      i = ie, j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  return a.size() - i < b.size() - j || (a.size() - i == b.size() - j && a < b);
}

// The folder's image files in natural order, and the mask among them (names containing "mask").
Status ListImages(const fs::path& dir, std::vector<std::string>* images, std::string* mask) {
  std::vector<std::string> names, masks;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec) || !IsImageExtension(e.path().extension().string())) continue;
    const std::string n = e.path().filename().string();
    (Lower(n).find("mask") != std::string::npos ? masks : names).push_back(n);
  }
  if (masks.size() > 1) {
    std::sort(masks.begin(), masks.end());
    return DataError("the dataset folder holds " + std::to_string(masks.size()) +
                     " images named like a mask ('" + masks[0] + "', '" + masks[1] +
                     "'); keep one, or list the images in images.txt");
  }
  std::sort(names.begin(), names.end(), NaturalLess);
  for (const auto& n : names) images->push_back((dir / n).string());
  *mask = masks.empty() ? std::string() : (dir / masks[0]).string();
  return Status::Ok();
}

// Image files named in images.txt (one per line, relative to the folder).
Status ReadImageList(const fs::path& dir, const std::string& list_path, const ReadOptions& o,
                     std::vector<std::string>* images) {
  auto lines = ReadTextLines(list_path, o.confine_to);
  if (!lines.ok()) return lines.status();
  std::error_code ec;
  for (const TextLine& l : *lines) {
    const fs::path f = dir / l.text;
    // A name outside the folder is refused before the file system is asked about it (a server
    // dataset must not learn what exists outside it).
    if (fs::path(l.text).is_absolute() || !LpNameInside(l.text, dir, o.confine_to) ||
        !fs::is_regular_file(f, ec))
      return NotFound(AtLine(
          DatasetRelative(list_path, o.confine_to), l.number,
          "image '" + l.text + "' not found in the dataset folder; names are relative to it"));
    images->push_back(f.string());
  }
  return Status::Ok();
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
  const std::string shown_lights = DatasetRelative(lights_path, o.confine_to);
  // Which images, in light order (see the top of this file).
  std::vector<std::string> files;
  std::string mask, how;
  const fs::path list = fs::path(dir) / "images.txt";
  std::error_code ec;
  if (fs::is_regular_file(list, ec)) {
    MATFIT_RETURN_IF_ERROR(ReadImageList(dir, list.string(), o, &files));
    how = "images.txt lists";
  } else if (!FindNumbered(dir, name + ".0").empty()) {
    int n = 0;
    while (n < 1000000) {
      std::string f = FindNumbered(dir, name + "." + std::to_string(n));
      if (f.empty()) break;
      files.push_back(std::move(f));
      ++n;
    }
    if (n < count)
      return NotFound("image " + std::to_string(n) + " of '" + shown_lights +
                      "' not found: expected '" + name + "." + std::to_string(n) +
                      ".png' (or .jpg, .tif, ...) after " + name + ".0 to " + name + "." +
                      std::to_string(n - 1));
    mask = FindNumbered(dir, name + ".mask");
    how = "the folder has numbered images " + name + ".0 to " + name + "." + std::to_string(n - 1) +
          ":";
  } else {
    MATFIT_RETURN_IF_ERROR(ListImages(dir, &files, &mask));
    if (files.empty())
      return NotFound("no images beside '" + shown_lights + "': expected numbered images " + name +
                      ".0.png, ... or any image files (in light order by name), or images.txt");
    how = "the folder has";
  }
  if (int(files.size()) != count)
    return DataError("'" + shown_lights + "' lists " + std::to_string(count) + " lights but " +
                     how + " " + std::to_string(files.size()) +
                     " image(s): every image needs its light and every light its image; fix "
                     "lights.txt, or name the images in light order in images.txt");
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
    lights.push_back(*light);
  }
  ImageReadOptions io;
  io.color_space = o.color_space;
  io.confine_to = o.confine_to;
  auto stack = LoadStack(files, std::move(lights), io, o);
  if (!stack.ok()) return stack.status();
  if (!mask.empty()) MATFIT_RETURN_IF_ERROR(ApplyMaskFile(mask, o, &*stack));
  stack->layout = LayoutName(Layout::kLightsTxt);
  stack->source = dir;
  stack->object_name = name;
  return stack;
}

}  // namespace matfit
