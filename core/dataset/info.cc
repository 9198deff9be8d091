#include "core/dataset/info.h"
#include "core/warnings.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <span>

#include "core/near_lights.h"
#include "core/parallel.h"
#include "core/stack_band.h"

namespace matfit {
namespace {

std::string Fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string HumanBytes(double b) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  while (b >= 1024 && u < 4) b /= 1024, ++u;
  return Fmt(u == 0 ? "%.0f" : "%.1f", b) + " " + units[u];
}

constexpr float kBlackLevel = 1e-4f;  // linear; an image whose every sample is below is black

// True when some code of the plane is at least `bright`: the largest code of each 4096-code block
// (the loop vectorises to byte/word max), stopping at the first block that reaches it (an image
// with any lit pixel stops within its first blocks instead of reading the whole plane).
template <typename T>
bool AnyCodeAtLeast(std::span<const T> codes, int64_t bright) {
  constexpr size_t kBlock = 4096;
  for (size_t b = 0; b < codes.size(); b += kBlock) {
    T m = 0;
    for (T c : codes.subspan(b, std::min(kBlock, codes.size() - b))) m = std::max(m, c);
    if (m >= bright) return true;
  }
  return false;
}

// The first code that decodes to ≥ kBlackLevel when every code at or above it does too (a
// non-decreasing table: every transfer function matfit decodes with); -1 when no code does; -2
// for float stacks and other tables, which must be decoded.
int64_t FirstBrightCode(const LightStack& s) {
  const std::vector<float>& lut = s.lut();
  if (s.is_float() || !std::is_sorted(lut.begin(), lut.end())) return -2;
  const auto bright =
      std::find_if(lut.begin(), lut.end(), [](float v) { return v >= kBlackLevel; });
  return bright == lut.end() ? -1 : int64_t(bright - lut.begin());
}

// True when no finite sample of image i reaches kBlackLevel. With a first bright code the
// codes decide without decoding the image.
bool IsBlackImage(const LightStack& s, int i, int64_t first_bright) {
  if (first_bright == -1) return true;
  if (first_bright >= 0) {
    for (int c = 0; c < s.channels(); ++c) {
      if (s.sample_type() == SampleType::kUint8
              ? AnyCodeAtLeast(s.Codes<uint8_t>(i, c), first_bright)
              : AnyCodeAtLeast(s.Codes<uint16_t>(i, c), first_bright))
        return false;
    }
    return true;
  }
  std::vector<float> scratch(s.is_float() ? 0 : size_t(s.plane_size()));
  for (int c = 0; c < s.channels(); ++c) {
    const float* v = s.Texels(i, c, 0, int(s.plane_size()), scratch.data());
    for (int64_t p = 0; p < s.plane_size(); ++p)
      if (std::isfinite(v[p]) && v[p] >= kBlackLevel) return false;
  }
  return true;
}

}  // namespace

// Coverage thresholds of the warnings (docs/cli.md): a ring of 3 evenly spaced lights leaves
// 120° gaps, which Lambertian photometric stereo still handles.
constexpr double kMaxAzimuthGapDeg = 120.0, kMinElevationSpanDeg = 5.0;

namespace {

// "sRGB (8-bit default (sRGB)) x 12", one per distinct encoding and reason.
std::vector<std::string> EncodingCounts(const LightStack& s) {
  std::map<std::string, int> enc;
  for (size_t i = 0; i < s.encodings.size(); ++i)
    enc[s.encodings[i].ToString() + " (" +
        (i < s.encoding_reasons.size() ? s.encoding_reasons[i] : "") + ")"]++;
  std::vector<std::string> out;
  for (auto& [k, c] : enc) out.push_back(k + " x " + std::to_string(c));
  return out;
}

}  // namespace

std::string DescribeReadEncoding(const LightStack& s) {
  std::string out;
  for (const std::string& e : EncodingCounts(s)) out += (out.empty() ? "" : "; ") + e;
  return out;
}

DatasetInfo ComputeDatasetInfo(const LightStack& s) {
  DatasetInfo info;
  info.layout = s.layout;
  info.source = s.source;
  info.object_name = s.object_name;
  info.images = s.num_images();
  // A band of a distributed stack reports the whole stack (the ranks' figures summed).
  info.width = s.width(), info.height = s.full_height(), info.channels = s.channels();
  // Every band's samples and mask; the decode table once.
  const int64_t table = int64_t(s.lut().size() * sizeof(float));
  int64_t texel_counts[2] = {int64_t(s.MemoryBytes()) - table, s.MaskedTexels()};
  SumOverBands(s, texel_counts, 2);
  info.memory_bytes = size_t(texel_counts[0] + table);
  info.sample_type = SampleTypeName(s.sample_type());
  info.view_theta_deg = s.view_theta_deg, info.view_phi_deg = s.view_phi_deg;
  info.view_theta_min = info.view_theta_max = s.view_theta_deg;
  if (s.is_multi_view()) {
    const auto groups = ViewGroups(s);
    info.views = int(groups.size());
    for (const auto& g : groups) {
      const double t = s.lights()[size_t(g[0])].view_theta_deg;
      info.view_theta_min = std::min(info.view_theta_min, t);
      info.view_theta_max = std::max(info.view_theta_max, t);
    }
  }
  info.has_mask = s.has_mask();
  info.mask_source = s.mask_source;
  info.source_width = s.source_width, info.source_height = s.source_height;
  info.crop_x = s.crop_x, info.crop_y = s.crop_y;
  info.cropped = s.crop_w > 0;
  info.masked_texels = texel_counts[1];
  if (s.has_light_positions()) {
    info.near_lights = true;
    info.near_distance_min = 1e300;
    for (const LightSample& l : s.lights()) {
      const double d = Length(l.position);
      info.near_distance_min = std::min(info.near_distance_min, d);
      info.near_distance_max = std::max(info.near_distance_max, d);
      // Over the corners of the stack: how far apart its texels see the light.
      Vec3 seen[4];
      int k = 0;
      for (double y : {0.0, double(s.height() - 1)})
        for (double x : {0.0, double(s.width() - 1)})
          seen[k++] = Normalize(l.position - NearTexelPosition(s, x, y));
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < a; ++b)
          info.near_direction_spread_deg =
              std::max(info.near_direction_spread_deg, AngleBetweenDeg(seen[a], seen[b]));
    }
  }
  const int n = s.num_images();

  // Light distribution.
  std::map<int, int> groups;
  std::vector<double> phis;
  info.theta_min = 1e9, info.theta_max = -1e9;
  info.intensity_min = 1e300, info.intensity_max = -1e300;
  int below = 0;
  Eigen::MatrixXd L(n, 3);
  for (int i = 0; i < n; ++i) {
    const LightSample& l = s.lights()[i];
    groups[int(std::lround(l.theta_deg / 15.0)) * 15]++;
    info.theta_min = std::min(info.theta_min, l.theta_deg);
    info.theta_max = std::max(info.theta_max, l.theta_deg);
    if (l.theta_deg > 1e-6) phis.push_back(l.phi_deg);
    if (l.direction.z <= 0) ++below;
    for (int c = 0; c < 3; ++c) {
      info.intensity_min = std::min(info.intensity_min, l.intensity[c]);
      info.intensity_max = std::max(info.intensity_max, l.intensity[c]);
    }
    L.row(i) << l.direction.x, l.direction.y, l.direction.z;
    info.mean_light += l.direction / double(std::max(1, n));
  }
  for (auto [t, c] : groups) info.theta_groups.push_back({t, c});
  std::sort(phis.begin(), phis.end());
  if (phis.size() >= 2) {
    double gap = 360.0 - phis.back() + phis.front();
    for (size_t i = 1; i < phis.size(); ++i) gap = std::max(gap, phis[i] - phis[i - 1]);
    info.max_azimuth_gap_deg = gap;
  } else {
    info.max_azimuth_gap_deg = 360;
  }
  if (n > 0) {
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(L);
    const auto sv = svd.singularValues();
    for (int k = 0; k < 3 && k < sv.size(); ++k) info.singular_values[k] = sv[k];
    const double tol = 1e-9 * std::max(1.0, info.singular_values[0]);
    info.rank = int((sv.array() > tol).count());
    info.condition_number = info.rank == 3 ? info.singular_values[0] / info.singular_values[2]
                                           : std::numeric_limits<double>::infinity();
  }

  info.encodings = EncodingCounts(s);

  // Clipping and non-finite samples.
  int64_t sat = 0;
  for (size_t i = 0; i < s.saturated_pixels.size(); ++i) {
    sat += s.saturated_pixels[i];
    const double f =
        double(s.saturated_pixels[i]) / double(std::max<int64_t>(1, s.full_plane_size()));
    if (f > info.worst_saturated_fraction) {
      info.worst_saturated_fraction = f;
      info.worst_saturated_file = i < s.image_files.size() ? s.image_files[i] : std::to_string(i);
    }
  }
  info.saturated_fraction = double(sat) / double(std::max<int64_t>(1, s.full_plane_size() * n));
  for (int64_t v : s.nonfinite_samples) info.nonfinite_samples += v;

  // Black images: no sample reaches kBlackLevel.
  std::vector<char> is_black(size_t(n), 0);
  const int64_t first_bright = FirstBrightCode(s);
  ParallelFor(0, n, [&](int64_t i0, int64_t i1) {
    for (int64_t i = i0; i < i1; ++i) is_black[size_t(i)] = IsBlackImage(s, int(i), first_bright);
  });
  std::vector<int64_t> lit(static_cast<size_t>(n));  // bands in which image i is not black
  for (int i = 0; i < n; ++i) lit[size_t(i)] = !is_black[size_t(i)];
  SumOverBands(s, lit.data(), n);
  std::vector<int> black;
  for (int i = 0; i < n; ++i)
    if (lit[size_t(i)] == 0) black.push_back(i);

  // Warnings.
  auto& w = info.warnings;
  w = s.read_warnings;
  // An encoding from the bit-depth convention is a guess: say so (the γ check of `info` and
  // `fit` then says when the data contradict it).
  int assumed_srgb = 0, assumed_linear = 0;
  for (const auto& r : s.encoding_reasons)
    assumed_srgb += r == "8-bit default (sRGB)",
        assumed_linear += r.rfind("default for high", 0) == 0;
  if (assumed_srgb + assumed_linear > 0)
    w.push_back(
        Warning(WarningCode::kEncodingAssumed,
                std::to_string(assumed_srgb + assumed_linear) + " of " +
                    std::to_string(s.encoding_reasons.size()) +
                    " images carry no colour metadata and were read as " +
                    (assumed_srgb && assumed_linear ? "sRGB (8-bit) or linear (16-bit and deeper)"
                     : assumed_srgb                 ? "sRGB (the 8-bit convention)"
                                    : "linear (the convention for 16-bit and deeper)") +
                    "; if the camera wrote them otherwise, pass --color-space " +
                    (assumed_srgb ? "linear" : "srgb")));
  if (n < 3)
    w.push_back(
        Warning(WarningCode::kTooFewLights, "only " + std::to_string(n) +
                                                " light(s): photometric stereo needs at least 3 "
                                                "non-coplanar lights"));
  else if (info.rank < 3)
    w.push_back(Warning(WarningCode::kCoplanarLights,
                        "the lights are coplanar (light matrix rank " + std::to_string(info.rank) +
                            "): normals cannot be recovered; add lights out of that plane"));
  else if (info.condition_number > 30)
    w.push_back(Warning(WarningCode::kIllConditionedLights,
                        "ill-conditioned light matrix (condition number " +
                            Fmt("%.1f", info.condition_number) +
                            "): lights are nearly coplanar, fitted normals will amplify noise"));
  if (below > 0)
    w.push_back(
        Warning(WarningCode::kLightsBelowHorizon,
                std::to_string(below) + " light(s) at or below the surface plane (θ ≥ 90°)"));
  // Within each view (a multi-view stack repeats its lights from every view).
  bool duplicate = false;
  for (const std::vector<int>& g : ViewGroups(s))
    for (size_t a = 0; a < g.size() && !duplicate; ++a)
      for (size_t b = a + 1; b < g.size() && !duplicate; ++b)
        if (AngleBetweenDeg(s.lights()[g[a]].direction, s.lights()[g[b]].direction) < 0.05) {
          w.push_back(Warning(WarningCode::kDuplicateLights,
                              "lights " + std::to_string(g[a]) + " and " + std::to_string(g[b]) +
                                  " have the same direction" +
                                  (s.is_multi_view() ? " and view" : "")));
          duplicate = true;
        }
  if (info.saturated_fraction > 0.001)
    w.push_back(Warning(WarningCode::kClippedPixels,
                        Fmt("%.2f", 100 * info.saturated_fraction) +
                            "% of pixels are clipped at the maximum code (worst: '" +
                            info.worst_saturated_file + "', " +
                            Fmt("%.2f", 100 * info.worst_saturated_fraction) +
                            "%); lower the exposure or bracket to HDR"));
  if (info.nonfinite_samples > 0)
    w.push_back(Warning(WarningCode::kNonfiniteSamples,
                        std::to_string(info.nonfinite_samples) + " NaN/Inf samples in the images"));
  if (!black.empty())
    w.push_back(Warning(WarningCode::kBlackImages,
                        std::to_string(black.size()) +
                            " image(s) are black (max < 1e-4), first: '" +
                            (size_t(black[0]) < s.image_files.size() ? s.image_files[black[0]]
                                                                     : std::to_string(black[0])) +
                            "'"));
  if (n >= 3 && info.max_azimuth_gap_deg > kMaxAzimuthGapDeg)
    w.push_back(Warning(WarningCode::kAzimuthGap,
                        "the lights leave a " + Fmt("%.0f", info.max_azimuth_gap_deg) +
                            "° gap in azimuth (more than " + Fmt("%.0f", kMaxAzimuthGapDeg) +
                            "°): surfaces tilted towards it are lit from one side only and "
                            "their normals are extrapolated; add lights in that direction"));
  if (n >= 3 && info.theta_max - info.theta_min < kMinElevationSpanDeg)
    w.push_back(Warning(WarningCode::kElevationSpan,
                        "every light lies at θl " + Fmt("%.1f", info.theta_min) + "°..." +
                            Fmt("%.1f", info.theta_max) +
                            "°: models that need several elevations (ptm, hsh, specular "
                            "lobes) are poorly determined; add lights at other elevations"));
  if (info.has_mask && info.masked_texels == 0)
    w.push_back(Warning(WarningCode::kEmptyMask, "the mask selects no texel"));
  return info;
}

std::string FormatDatasetInfo(const DatasetInfo& d) {
  std::string o;
  o += "dataset      " + d.source + "\n";
  o += "layout       " + d.layout +
       (d.detection_reason.empty() ? "" : "  (detected: " + d.detection_reason + ")") + "\n";
  if (!d.object_name.empty()) o += "object       " + d.object_name + "\n";
  o += "images       " + std::to_string(d.images) + " x " + std::to_string(d.width) + "x" +
       std::to_string(d.height) + ", " + std::to_string(d.channels) + " channel(s), " +
       HumanBytes(double(d.memory_bytes)) + " as " +
       (d.sample_type.empty() ? "float32" : d.sample_type) + "\n";
  if (d.cropped)
    o += "region       " + std::to_string(d.width) + "x" + std::to_string(d.height) + " at " +
         std::to_string(d.crop_x) + "," + std::to_string(d.crop_y) + " of the " +
         std::to_string(d.source_width) + "x" + std::to_string(d.source_height) +
         " images (--crop)\n";
  if (d.views > 1)
    o += "views        " + std::to_string(d.views) + ", θv " + Fmt("%.1f", d.view_theta_min) +
         "°…" + Fmt("%.1f", d.view_theta_max) +
         "°; reference (most frontal) θv=" + Fmt("%.1f", d.view_theta_deg) +
         "° φv=" + Fmt("%.1f", d.view_phi_deg) + "°\n";
  else
    o += "view         θv=" + Fmt("%.1f", d.view_theta_deg) +
         "° φv=" + Fmt("%.1f", d.view_phi_deg) + "°\n";
  for (const auto& e : d.encodings) o += "colour       " + e + "\n";
  o += "mask         " +
       (d.has_mask ? std::to_string(d.masked_texels) + " of " +
                         std::to_string(int64_t(d.width) * d.height) + " texels" +
                         (d.mask_source.empty() ? "" : ", from the " + d.mask_source)
        : d.mask_source.empty() ? std::string("none (all texels)")
                                : d.mask_source + " (all texels)") +
       "\n";
  o += "lights       θl " + Fmt("%.1f", d.theta_min) + "°..." + Fmt("%.1f", d.theta_max) +
       "°, largest azimuth gap " + Fmt("%.0f", d.max_azimuth_gap_deg) + "°, intensity " +
       Fmt("%.3g", d.intensity_min) + "..." + Fmt("%.3g", d.intensity_max) + "\n";
  if (d.near_lights)
    o += "near lights  at " + Fmt("%.0f", d.near_distance_min) + "..." +
         Fmt("%.0f", d.near_distance_max) +
         " px from the image centre (light_positions.txt); a light's direction varies by up to " +
         Fmt("%.2f", d.near_direction_spread_deg) +
         "° over the texels (fits use per-texel directions and 1/r² fall-off)\n";
  o += "θl groups   ";
  for (const auto& g : d.theta_groups)
    o += " " + std::to_string(g.theta_deg) + "°:" + std::to_string(g.count);
  o += "\n";
  o += "mean light   (" + Fmt("%.4f", d.mean_light.x) + ", " + Fmt("%.4f", d.mean_light.y) + ", " +
       Fmt("%.4f", d.mean_light.z) + ")\n";
  o += "light matrix singular values " + Fmt("%.4g", d.singular_values[0]) + " " +
       Fmt("%.4g", d.singular_values[1]) + " " + Fmt("%.4g", d.singular_values[2]) + ", rank " +
       std::to_string(d.rank) + ", condition number " +
       (std::isfinite(d.condition_number) ? Fmt("%.3f", d.condition_number) : std::string("inf")) +
       "\n";
  o += "clipped      " + Fmt("%.3f", 100 * d.saturated_fraction) + "% of pixels\n";
  if (!d.tone_curve.empty()) o += "tone curve   " + d.tone_curve + "\n";
  if (d.warnings.empty()) o += "warnings     none\n";
  for (const auto& w : d.warnings) o += "warning      " + w + "\n";
  return o;
}

std::string DatasetInfoJson(const DatasetInfo& d) {
  nlohmann::json groups = nlohmann::json::array();
  for (const auto& g : d.theta_groups)
    groups.push_back({{"theta_deg", g.theta_deg}, {"count", g.count}});
  nlohmann::json j = {
      {"source", d.source},
      {"layout", d.layout},
      {"detection_reason", d.detection_reason},
      {"object", d.object_name},
      {"images", d.images},
      {"width", d.width},
      {"height", d.height},
      {"channels", d.channels},
      {"memory_bytes", d.memory_bytes},
      {"sample_type", d.sample_type},
      {"view", {{"theta_deg", d.view_theta_deg}, {"phi_deg", d.view_phi_deg}}},
      {"views",
       {{"count", d.views},
        {"theta_min_deg", d.view_theta_min},
        {"theta_max_deg", d.view_theta_max}}},
      {"encodings", d.encodings},
      {"mask_texels", d.has_mask ? nlohmann::json(d.masked_texels) : nlohmann::json()},
      {"mask_source", d.mask_source},
      {"near_lights", d.near_lights
                          ? nlohmann::json({{"distance_min_px", d.near_distance_min},
                                            {"distance_max_px", d.near_distance_max},
                                            {"direction_spread_deg", d.near_direction_spread_deg}})
                          : nlohmann::json()},
      {"crop", d.cropped ? nlohmann::json({{"x", d.crop_x},
                                           {"y", d.crop_y},
                                           {"width", d.width},
                                           {"height", d.height},
                                           {"source_width", d.source_width},
                                           {"source_height", d.source_height}})
                         : nlohmann::json()},
      {"theta_groups", groups},
      {"theta_min_deg", d.theta_min},
      {"theta_max_deg", d.theta_max},
      {"max_azimuth_gap_deg", d.max_azimuth_gap_deg},
      {"mean_light", {d.mean_light.x, d.mean_light.y, d.mean_light.z}},
      {"singular_values", {d.singular_values[0], d.singular_values[1], d.singular_values[2]}},
      {"rank", d.rank},
      {"condition_number",
       std::isfinite(d.condition_number) ? nlohmann::json(d.condition_number) : nlohmann::json()},
      {"saturated_fraction", d.saturated_fraction},
      {"nonfinite_samples", d.nonfinite_samples},
      {"tone_curve", d.tone_curve.empty() ? nlohmann::json() : nlohmann::json(d.tone_curve)},
      {"tone_verdict", d.tone_verdict.empty() ? nlohmann::json() : nlohmann::json(d.tone_verdict)},
      {"warnings", d.warnings}};
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace matfit
