// Bonn UBO2003 and UTIA BTF folders: angles parsed from file names, one view selected or all.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <tuple>

#include "core/dataset/btf_names.h"
#include "core/dataset/dataset.h"
#include "core/dataset/stack_loader.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

struct Entry {
  std::string path;
  BtfName angles;
};

// Regular image files in dir and its immediate subfolders (one folder per view in Bonn).
std::vector<fs::path> CandidateFiles(const fs::path& dir) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.is_regular_file(ec) && IsImageExtension(e.path().extension().string()))
      files.push_back(e.path());
    else if (e.is_directory(ec))
      for (const auto& f : fs::directory_iterator(e.path(), ec))
        if (f.is_regular_file(ec) && IsImageExtension(f.path().extension().string()))
          files.push_back(f.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string ViewLabel(double tv, double pv) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "θv=%g° φv=%g°", tv, pv);
  return buf;
}

}  // namespace

StatusOr<LightStack> ReadBtfFolder(const std::string& dir, Layout layout, const ReadOptions& o) {
  const bool bonn = layout == Layout::kBonn;
  const char* pattern =
      bonn ? "'NNNNN tlAAA plBBB tvCCC pvDDD.jpg'" : "'tl000_pl000_tv000_pv000.png'";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return NotFound("dataset folder '" + dir + "' does not exist");

  std::map<std::pair<long, long>, std::vector<Entry>> views;  // key: angles in millidegrees
  for (const fs::path& f : CandidateFiles(dir)) {
    BtfName a;
    const std::string name = f.filename().string();
    if (!(bonn ? ParseBonnName(name, &a) : ParseUtiaName(name, &a))) continue;
    if (a.theta_l > 180 || a.phi_l > 360 || a.theta_v >= 90 || a.phi_v > 360)
      return DataError("'" + f.string() +
                       "': angle out of range in the file name (need θl ≤ 180, "
                       "φ ≤ 360, θv < 90 degrees)");
    views[{std::lround(a.theta_v * 1000), std::lround(a.phi_v * 1000)}].push_back({f.string(), a});
  }
  if (views.empty())
    return DataError("no image in '" + dir + "' (or its view subfolders) is named like " + pattern +
                     "; is this a " + LayoutName(layout) + " BTF folder?");

  // Select the view: the requested one exactly, else the most frontal; or every view.
  const std::vector<Entry>* chosen = nullptr;
  std::vector<Entry> every;
  if (o.all_views) {
    // θv = 0 is one direction whatever φv says: two such views would be one view twice.
    const std::pair<long, long>* overhead = nullptr;
    for (const auto& [k, v] : views) {
      if (k.first != 0) continue;
      if (overhead)
        return DataError("views θv=0° φv=" + std::to_string(overhead->second / 1000) +
                         "° and φv=" + std::to_string(k.second / 1000) + "° in '" + dir +
                         "' are the same (straight-down) view; keep one of them");
      overhead = &k;
    }
    // Views in (θv, φv) order (the map's), each view's images sorted by light below; the most
    // frontal view is the stack's reference view.
    for (const auto& [k, v] : views) {
      std::vector<Entry> e = v;
      std::sort(e.begin(), e.end(), [](const Entry& a, const Entry& b) {
        return std::tie(a.angles.theta_l, a.angles.phi_l) <
               std::tie(b.angles.theta_l, b.angles.phi_l);
      });
      every.insert(every.end(), e.begin(), e.end());
      if (!chosen || k.first < std::lround(chosen->front().angles.theta_v * 1000)) chosen = &v;
    }
  } else if (o.view) {
    const auto key =
        std::make_pair(std::lround(o.view->theta_deg * 1000), std::lround(o.view->phi_deg * 1000));
    auto it = views.find(key);
    if (it == views.end()) {
      std::string avail;
      int listed = 0;
      for (const auto& [k, v] : views) {
        if (listed++ == 12) {
          avail += ", ...";
          break;
        }
        avail += (avail.empty() ? "" : ", ") + std::to_string(k.first / 1000) + "," +
                 std::to_string(k.second / 1000);
      }
      return InvalidArgument("view " + ViewLabel(o.view->theta_deg, o.view->phi_deg) +
                             " is not in '" + dir + "'; available views (θ,φ): " + avail);
    }
    chosen = &it->second;
  } else {
    for (const auto& [k, v] : views)
      if (!chosen || k.first < std::lround(chosen->front().angles.theta_v * 1000)) chosen = &v;
  }

  const BtfName reference = chosen->front().angles;
  std::vector<Entry> entries = o.all_views ? std::move(every) : *chosen;
  if (!o.all_views)
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
      return std::tie(a.angles.theta_l, a.angles.phi_l) <
             std::tie(b.angles.theta_l, b.angles.phi_l);
    });
  std::vector<std::string> files;
  std::vector<LightSample> lights;
  for (size_t i = 0; i < entries.size(); ++i) {
    const BtfName& a = entries[i].angles;
    const BtfName* prev = i > 0 ? &entries[i - 1].angles : nullptr;
    if (prev && a.theta_l == prev->theta_l && a.phi_l == prev->phi_l &&
        a.theta_v == prev->theta_v && a.phi_v == prev->phi_v)
      return DataError("'" + entries[i - 1].path + "' and '" + entries[i].path +
                       "' have the same light and view angles; remove one of them");
    LightSample s;
    s.direction = DirectionFromAnglesDeg(a.theta_l, a.phi_l);
    s.theta_deg = a.theta_l;
    s.phi_deg = a.phi_l;
    if (o.all_views) {
      s.has_view = true;
      s.view = DirectionFromAnglesDeg(a.theta_v, a.phi_v);
      s.view_theta_deg = a.theta_v, s.view_phi_deg = a.phi_v;
    }
    files.push_back(entries[i].path);
    lights.push_back(s);
  }
  ImageReadOptions io;
  io.color_space = o.color_space;
  io.confine_to = o.confine_to;
  auto stack = LoadStack(files, std::move(lights), io, o);
  if (!stack.ok()) return stack.status();
  const BtfName& v = reference;
  stack->view_theta_deg = v.theta_v;
  stack->view_phi_deg = v.phi_v;
  stack->view_direction = DirectionFromAnglesDeg(v.theta_v, v.phi_v);
  stack->layout = LayoutName(layout);
  stack->source = dir;
  stack->object_name = FolderName(dir);
  return stack;
}

}  // namespace matfit
