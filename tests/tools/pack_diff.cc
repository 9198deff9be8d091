// matfit_pack_diff A B: whether two material packs (or two `matfit leaf` outputs: leaves.json, the
// sheet images and every leaf pack) hold the same fit (the MPI tests compare a
// distributed fit with a single process's). Float maps (EXR) agree within --tolerance (default
// 1e-6, absolute, the same NaN/Inf positions); 8/16-bit maps (PNG) within one code, except the
// status map, which must be identical; report.json and material.json have the same keys, strings
// and figures to 6 significant digits (timings excepted). Prints every difference; exit 1 when
// there is one, 2 on a usage or read error.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "core/image_io.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

int differences = 0;

void Differ(const std::string& what) {
  ++differences;
  std::printf("DIFF %s\n", what.c_str());
}

bool Timing(const std::string& key) {
  // When and how long: the only figures that may differ between two runs of one fit.
  return key == "timings" || key == "time" || key.ends_with("_seconds") ||
         key == "render_ns_per_pixel";
}

void CompareJson(const json& a, const json& b, const std::string& at) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    if (x == y || (std::isnan(x) && std::isnan(y))) return;
    if (std::abs(x - y) <= 1e-6 * std::max(std::abs(x), std::abs(y))) return;
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s: %.9g vs %.9g", at.c_str(), x, y);
    return Differ(buf);
  }
  if (a.type() != b.type()) return Differ(at + ": " + a.dump() + " vs " + b.dump());
  if (a.is_object()) {
    std::set<std::string> keys;
    for (auto& [k, v] : a.items()) keys.insert(k);
    for (auto& [k, v] : b.items()) keys.insert(k);
    for (const std::string& k : keys) {
      if (Timing(k)) continue;
      if (!a.contains(k) || !b.contains(k)) {
        Differ(at + "." + k + ": only in " + (a.contains(k) ? "the first" : "the second"));
        continue;
      }
      CompareJson(a[k], b[k], at + "." + k);
    }
    return;
  }
  if (a.is_array()) {
    if (a.size() != b.size())
      return Differ(at + ": arrays of " + std::to_string(a.size()) + " and " +
                    std::to_string(b.size()));
    for (size_t i = 0; i < a.size(); ++i)
      CompareJson(a[i], b[i], at + "[" + std::to_string(i) + "]");
    return;
  }
  if (a != b) Differ(at + ": " + a.dump() + " vs " + b.dump());
}

bool ReadJson(const fs::path& p, json* out) {
  std::ifstream in(p);
  if (!in) return false;
  std::stringstream s;
  s << in.rdbuf();
  *out = json::parse(s.str(), nullptr, false);
  return !out->is_discarded();
}

template <typename T>
void CompareCodes(const std::vector<T>& a, const std::vector<T>& b, bool exact,
                  const std::string& name) {
  int64_t off = 0, worst = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const int64_t d = std::llabs(int64_t(a[i]) - int64_t(b[i]));
    off += d != 0, worst = std::max(worst, d);
  }
  if (worst > (exact ? 0 : 1))
    Differ(name + ": " + std::to_string(off) + " codes differ, by up to " + std::to_string(worst));
  else if (off > 0)
    std::printf("note %s: %lld codes differ by one\n", name.c_str(), (long long)off);
}

void CompareMap(const fs::path& a, const fs::path& b, double tolerance) {
  const std::string name = a.filename().string();
  if (!fs::exists(b)) return Differ(name + ": only in the first pack");
  matfit::ImageReadOptions o;
  o.all_channels = true;
  o.color_space = matfit::ColorSpaceChoice::kLinear;
  auto x = matfit::ReadImageNative(a.string(), o), y = matfit::ReadImageNative(b.string(), o);
  if (!x.ok() || !y.ok()) return Differ(name + ": cannot read");
  if (x->width != y->width || x->height != y->height || x->channels != y->channels ||
      x->type != y->type)
    return Differ(name + ": different size, channels or depth");
  if (x->type == matfit::SampleType::kUint8)
    return CompareCodes(x->u8, y->u8, name == "status.png", name);
  if (x->type == matfit::SampleType::kUint16)
    return CompareCodes(x->u16, y->u16, name == "status.png", name);
  double worst = 0;
  for (int c = 0; c < x->channels; ++c) {
    const auto p = x->floats.Plane(c), q = y->floats.Plane(c);
    for (size_t i = 0; i < p.size(); ++i) {
      if (std::isfinite(p[i]) != std::isfinite(q[i]) ||
          (!std::isfinite(p[i]) && !(p[i] == q[i] || (std::isnan(p[i]) && std::isnan(q[i])))))
        return Differ(name + ": a non-finite value at a different place");
      if (std::isfinite(p[i])) worst = std::max(worst, double(std::abs(p[i] - q[i])));
    }
  }
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s: max |difference| %.3g", name.c_str(), worst);
  if (worst > tolerance) Differ(buf);
  std::printf("map  %s\n", buf);
}

// Two material packs: their JSON files and every map.
bool ComparePack(const fs::path& a, const fs::path& b, double tolerance) {
  for (const char* file : {"report.json", "material.json"}) {
    json x, y;
    if (!ReadJson(a / file, &x) || !ReadJson(b / file, &y)) {
      std::fprintf(stderr, "cannot read %s in both packs (%s, %s)\n", file, a.c_str(), b.c_str());
      return false;
    }
    CompareJson(x, y, a.filename().string() + "/" + file);
  }
  std::set<std::string> maps;
  for (const auto& e : fs::directory_iterator(a / "maps")) maps.insert(e.path().filename());
  for (const auto& e : fs::directory_iterator(b / "maps"))
    if (!maps.count(e.path().filename()))
      Differ(e.path().filename().string() + ": only in the second pack");
  for (const std::string& m : maps) CompareMap(a / "maps" / m, b / "maps" / m, tolerance);
  return true;
}

// Two `matfit leaf` outputs: leaves.json, the sheet's images and every leaf's pack.
bool CompareLeafFolders(const fs::path& a, const fs::path& b, double tolerance) {
  json x, y;
  if (!ReadJson(a / "leaves.json", &x) || !ReadJson(b / "leaves.json", &y)) {
    std::fprintf(stderr, "cannot read leaves.json in both folders\n");
    return false;
  }
  CompareJson(x, y, "leaves.json");
  for (const char* f : {"segmentation.png", "transmission.exr"})
    CompareMap(a / f, b / f, tolerance);
  for (const json& leaf : x["leaves"]) {
    const std::string pack = leaf.value("pack", "");
    if (pack.empty() || pack.find('/') != std::string::npos) return false;
    if (!ComparePack(a / pack, b / pack, tolerance)) return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: matfit_pack_diff A B [--tolerance T]   (packs or leaf folders)\n");
    return 2;
  }
  const fs::path a = argv[1], b = argv[2];
  const double tolerance =
      argc >= 5 && std::string(argv[3]) == "--tolerance" ? std::strtod(argv[4], nullptr) : 1e-6;
  const bool read = fs::exists(a / "leaves.json") ? CompareLeafFolders(a, b, tolerance)
                                                  : ComparePack(a, b, tolerance);
  if (!read) return 2;
  std::printf("%s: %d difference(s)\n", differences ? "DIFFERENT" : "same", differences);
  return differences ? 1 : 0;
}
