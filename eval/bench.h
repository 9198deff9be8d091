// `matfit bench`: every method of the ladder on a fixed suite — synthetic materials with ground
// truth at several sizes, and the real sets in ../shared/data scored by held-out lights — timed
// and scored on the same data (docs/benchmarks.md, "speed vs accuracy").
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/material_maps.h"
#include "core/progress.h"
#include "core/status.h"
#include "eval/multi_view_bench.h"

namespace matfit::eval {

struct BenchCase {
  std::string name;      // e.g. "plastic-64", "psm-cat"
  std::string material;  // synthetic material (core/synth/materials.h), empty for real data
  std::string lights = "bonn81";
  int size = 64;
  std::string path;    // real dataset folder
  int downsample = 1;  // real data: box factor after cropping to the mask
  // A leaf scan (top-lit + back-lit images): scored on its flat-fielded top-lit stack over the
  // segmented leaves (leaf/sheet.h). Fits are per texel, so this equals every leaf's held-out
  // error pooled by texel count.
  bool leaf_sheet = false;
};

struct BenchOptions {
  bool quick = false;                // the suite and repeats of --quick (< 2 min on 2 cores)
  std::string shared_data;           // ../shared/data; real cases are skipped when absent
  std::vector<std::string> methods;  // empty: the whole ladder
  int repeats = 0;                   // fit timings per point (median); 0 = 1 quick, 3 full
  int holdout = 4;                   // k-fold held-out lights
  bool loo = true;                   // real cases: also leave-one-out held-out lights
  std::vector<std::string> cases;    // empty: the whole suite; else these case names only
  // The multi-view cases (eval/multi_view_bench.h): run when neither cases nor methods narrow
  // the suite, or when cases names one.
  bool multi_view = true;
  ProgressFn progress;  // points done / total

  bool Check(std::string* why) const;
};

struct BenchPoint {
  std::string method, dataset;
  bool ok = true;
  std::string error;  // when the method refused the dataset
  int64_t texels = 0;
  int images = 0, parameters = 0, bytes_per_texel = 0;
  double fit_seconds = 0;  // median of the repeats
  double texels_per_second = 0;
  double render_ns_per_pixel = 0;  // CPU shading function, one light, 3 channels (median)
  double deviation_percent = 0;    // reconstruction at the fitted lights (METHODS.md §2)
  std::map<int, double> deviation_percent_by_theta;
  // Held-out RMSE over the common texel set (every unmasked texel, flagged ones with their stored
  // values: fit/metrics.h), which the charts and rankings use; and over the texels the fold fits
  // kept (the figure before 2026-12-04).
  double heldout_rmse = NAN, heldout_rmse_fitted = NAN, heldout_deviation_percent = NAN;
  double heldout_psnr_srgb8_db = NAN;  // the same folds, 8-bit sRGB PSNR (common texel set)
  // Real cases (BenchOptions::loo): leave-one-out over the lights, common texel set; linear RMSE
  // and PSNR, and 8-bit sRGB PSNR (fit/metrics.h).
  double loo_rmse = NAN, loo_psnr_db = NAN, loo_psnr_srgb8_db = NAN;
  // The bound's tightness against those held-out lights: median and p90 over texels of the
  // per-texel bound / held-out RMS (fit/confidence.h BoundRatio).
  double loo_bound_ratio_median = NAN, loo_bound_ratio_p90 = NAN;
  double loo_bound_exceeded_fraction = NAN;  // texels whose held-out error exceeds their bound
  std::optional<double> normal_mae_deg, albedo_rmse;
  std::optional<double> relight_rmse;  // vs truth over a 48-light dome (synthetic only)
  int64_t flagged_texels = 0;
  double bound_median = NAN;  // median per-texel error bound (fit/confidence.h)
};

struct Hl2Point {
  int directions = 0;                              // N_L
  double mean_error_percent = 0;                   // HL2 vs multipole, mean over 3 elevations
  std::vector<double> error_percent_by_elevation;  // π/2, π/4, π/8
  double precompute_seconds = 0;                   // fast method
};

struct BenchResult {
  std::vector<BenchCase> cases;
  std::vector<std::string> skipped;  // e.g. real data absent
  std::vector<BenchPoint> points;
  std::vector<MultiViewPoint> multi_view;  // storage vs held-out-view error (issue 17)
  std::vector<Hl2Point> hl2;               // leaf HL2 precompute: error vs N_L
  std::string hl2_leaf;                    // which leaf
  int holdout = 0, threads = 0;            // as run
  bool loo = false;
  double seconds = 0;
};

std::vector<BenchCase> DefaultSuite(bool quick);

// Runs the suite (reads the real datasets; fits; scores). Errors only for bad options.
StatusOr<BenchResult> RunBench(const BenchOptions& options);

// bench.json (schema "matfit.bench/1", keys a contract: docs/benchmarks.md).
std::string BenchJson(const BenchResult& result);

}  // namespace matfit::eval
