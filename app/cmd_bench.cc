// `matfit bench [--quick] --out DIR`: speed vs accuracy of every method on a fixed suite, the
// stability matrix, and their charts (SVG, plus PNG when rsvg-convert is installed).
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "app/commands.h"
#include "core/atomic_file.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "eval/bench.h"
#include "eval/bench_charts.h"
#include "eval/stability.h"

namespace matfit::app {
namespace {

namespace fs = std::filesystem;

struct BenchArgs {
  eval::BenchOptions bench;
  eval::StabilityOptions stability;
  std::string out, shared_data = "../shared/data", methods, cases;
  bool no_loo = false, no_multi_view = false, no_stability = false, stability_only = false,
       no_png = false, overwrite = false;
  bool quiet = false, stability_size_given = false;
  int threads = 0;
};

// Runs argv without a shell (paths may hold any character), its stdout to /dev/null; true on
// exit status 0.
bool RunProgram(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, args[0], &fa, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) return false;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return false;
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

std::vector<std::string> SplitComma(const std::string& s) {
  std::vector<std::string> out;
  size_t b = 0;
  while (b <= s.size() && !s.empty()) {
    const size_t e = s.find(',', b);
    out.push_back(s.substr(b, e == std::string::npos ? std::string::npos : e - b));
    if (e == std::string::npos) break;
    b = e + 1;
  }
  return out;
}

ProgressFn Bar(bool quiet, const char* stage, std::unique_ptr<ProgressReporter>* bar) {
  if (quiet) return {};
  *bar = std::make_unique<ProgressReporter>(stage);
  return [bar](int64_t d, int64_t t) {
    (*bar)->Update(d, t);
    return true;
  };
}

void PrintBench(const eval::BenchResult& r) {
  std::printf("\n%-14s %-15s %9s %10s %6s %9s %9s %9s %8s %8s %8s\n", "dataset", "method", "fit s",
              "texels/s", "B/tx", "render ns", "dev %", "held-out", "LOO", "LOO sRGB", "normal°");
  const auto opt = [](double v, const char* format) {
    char b[32] = "-";
    if (std::isfinite(v)) std::snprintf(b, sizeof b, format, v);
    return std::string(b);
  };
  for (const auto& p : r.points) {
    if (!p.ok) {
      std::printf("%-14s %-15s refused: %s\n", p.dataset.c_str(), p.method.c_str(),
                  p.error.c_str());
      continue;
    }
    std::printf("%-14s %-15s %9.3f %10.3g %6d %9.1f %9.4f %9s %8s %8s %8s\n", p.dataset.c_str(),
                p.method.c_str(), p.fit_seconds, p.texels_per_second, p.bytes_per_texel,
                p.render_ns_per_pixel, p.deviation_percent, opt(p.heldout_rmse, "%.4f").c_str(),
                opt(p.loo_rmse, "%.4f").c_str(), opt(p.loo_psnr_srgb8_db, "%.2f dB").c_str(),
                p.normal_mae_deg ? std::to_string(*p.normal_mae_deg).substr(0, 6).c_str() : "-");
  }
  if (!r.multi_view.empty())
    std::printf("\n%-17s %-23s %-9s %9s %10s %10s %9s %9s %8s\n", "multi-view case", "method",
                "family", "B/texel", "held-out", "texel RMS", "fit s", "texels/s", "normal°");
  for (const auto& p : r.multi_view) {
    if (!p.ok) {
      std::printf("%-17s %-23s refused: %s\n", p.dataset.c_str(), p.method.c_str(),
                  p.error.c_str());
      continue;
    }
    std::printf("%-17s %-23s %-9s %9.1f %10.4f %10.4f %9s %9s %8s\n", p.dataset.c_str(),
                p.method.c_str(), p.family.c_str(), p.bytes_per_texel, p.heldout_view_rmse,
                p.heldout_view_texel_rms, opt(p.fit_seconds, "%.3f").c_str(),
                opt(p.texels_per_second, "%.0f").c_str(),
                p.normal_mae_deg ? opt(*p.normal_mae_deg, "%.3f").c_str() : "-");
  }
  for (const auto& p : r.multi_view) {  // the held-out views by elevation
    if (!p.ok || p.heldout_view_rmse_by_theta.empty()) continue;
    std::string by;
    for (const auto& [tv, e] : p.heldout_view_rmse_by_theta)
      by += " " + std::to_string(tv) + "°:" + opt(e, "%.4f");
    std::printf("%-17s %-23s held-out RMSE by θv:%s\n", p.dataset.c_str(), p.method.c_str(),
                by.c_str());
  }
  for (const auto& s : r.skipped) std::printf("skipped: %s\n", s.c_str());
  for (const auto& h : r.hl2)
    std::printf("leaf HL2 N_L %4d: mean error %.2f %%, fast precompute %.1f ms\n", h.directions,
                h.mean_error_percent, 1e3 * h.precompute_seconds);
}

void PrintStability(const eval::StabilityResult& r) {
  int64_t silent = 0;
  std::printf("\nstability (%d², %zu methods × %zu perturbations): silent failures\n", r.size,
              r.methods.size(), r.perturbations.size());
  for (const auto& c : r.cells)
    if (c.applicable && c.silent > 0) {
      silent += c.silent;
      std::printf("  %-15s %-18s %lld texel(s) (%.2f %%), median error %.4g vs bound %.4g\n",
                  c.method.c_str(), c.perturbation.c_str(), (long long)c.silent,
                  100 * c.silent_fraction, c.error_median, c.bound_median);
    }
  std::printf("  total silent texels: %lld\n", (long long)silent);
}

int RunBench(BenchArgs& a) {
  if (a.out.empty()) return Fail("bench", "--out DIR is required");
  if (a.no_stability && a.stability_only)
    return Fail("bench", "--no-stability and --stability-only exclude each other");
  SetNumThreads(a.threads);
  a.bench.shared_data = a.shared_data;
  a.bench.cases = SplitComma(a.cases);
  a.bench.loo = !a.no_loo;
  a.bench.multi_view = !a.no_multi_view;
  a.stability.methods = SplitComma(a.methods);
  for (const auto& m : a.stability.methods)  // leaf-hl2 is a stability row only
    if (m != "leaf-hl2") a.bench.methods.push_back(m);
  if (a.bench.quick && !a.stability_size_given) a.stability.size = 20;
  std::string why;
  if (!a.bench.Check(&why) || !a.stability.Check(&why)) return Fail("bench", why.c_str());
  AtomicDir dir(a.out, "bench");
  if (Status s = dir.Begin(a.overwrite); !s.ok()) return Fail("bench", s.message().c_str());
  std::map<std::string, std::string> files;
  std::unique_ptr<ProgressReporter> bar;
  if (!a.stability_only) {
    a.bench.progress = Bar(a.quiet, "bench", &bar);
    auto r = eval::RunBench(a.bench);
    bar.reset();
    if (!r.ok()) return Fail("bench", r.status().message().c_str());
    files["bench.json"] = eval::BenchJson(*r);
    for (auto& [name, svg] : eval::BenchCharts(*r)) files["charts/" + name] = std::move(svg);
    if (!a.quiet) PrintBench(*r);
  }
  if (!a.no_stability) {
    a.stability.progress = Bar(a.quiet, "stability", &bar);
    auto r = eval::RunStability(a.stability);
    bar.reset();
    if (!r.ok()) return Fail("bench", r.status().message().c_str());
    files["stability.json"] = eval::StabilityJson(*r);
    for (auto& [name, svg] : eval::StabilityCharts(*r)) files["charts/" + name] = std::move(svg);
    if (!a.quiet) PrintStability(*r);
  }
  std::error_code ec;
  fs::create_directories(fs::path(dir.temp_path()) / "charts", ec);
  for (const auto& [name, text] : files)
    if (Status s = WriteFileAtomic((fs::path(dir.temp_path()) / name).string(), text); !s.ok())
      return Fail("bench", s.message().c_str());
  // PNG copies of the charts through librsvg's converter, when installed.
  const bool have_rsvg = !a.no_png && RunProgram({"rsvg-convert", "--version"});
  int png = 0;
  if (have_rsvg) {
    for (const auto& [name, text] : files) {
      if (name.rfind("charts/", 0) != 0) continue;
      const fs::path svg = fs::path(dir.temp_path()) / name;
      fs::path out = svg;
      out.replace_extension(".png");
      const std::string cmd =
          "rsvg-convert -b white -o '" + out.string() + "' '" + svg.string() + "'";
      if (std::system(cmd.c_str()) == 0)
        ++png;
      else
        std::fprintf(stderr, "matfit bench: warning: rsvg-convert failed on %s\n", name.c_str());
    }
  } else if (!a.no_png) {
    std::fprintf(stderr,
                 "matfit bench: warning: rsvg-convert not found (Debian package librsvg2-bin): "
                 "charts are SVG only\n");
  }
  if (Status s = dir.Commit(); !s.ok()) return Fail("bench", s.message().c_str());
  std::printf("\nwrote %s: %zu files, %d PNG charts\n", a.out.c_str(), files.size(), png);
  return 0;
}

}  // namespace

void RegisterBench(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<BenchArgs>();
  auto* sub = app.add_subcommand(
      "bench", "Speed vs accuracy of every method, the stability matrix, and charts");
  sub->add_flag("--quick", args->bench.quick, "small suite, one repeat (< 2 minutes)");
  sub->add_option("--out", args->out, "output folder (bench.json, stability.json, charts/)")
      ->required();
  sub->add_option("--shared-data", args->shared_data, "real datasets folder (psm/…)")
      ->capture_default_str();
  sub->add_option("--methods", args->methods, "comma-separated subset of the ladder");
  sub->add_option("--repeats", args->bench.repeats, "fit timings per point (median)");
  sub->add_option("--holdout", args->bench.holdout, "held-out-light folds")->capture_default_str();
  sub->add_option("--cases", args->cases,
                  "comma-separated subset of the suite (e.g. psm-gray,psm-cat)");
  sub->add_flag("--no-loo", args->no_loo, "real cases: skip the leave-one-out held-out lights");
  sub->add_option("--stability-size", args->stability.size,
                  "texels per side of stability cases (default 32, --quick 20)")
      ->each([args](const std::string&) { args->stability_size_given = true; });
  sub->add_flag("--no-multi-view", args->no_multi_view,
                "skip the multi-view BTF cases (storage vs held-out-view error)");
  sub->add_flag("--no-stability", args->no_stability, "skip the stability matrix");
  sub->add_flag("--stability-only", args->stability_only, "only the stability matrix");
  sub->add_flag("--no-png", args->no_png, "SVG charts only");
  sub->add_flag("--force", args->overwrite, kForceHelp);
  sub->add_option("--threads", args->threads, kThreadsHelp)->capture_default_str();
  sub->add_flag("--quiet", args->quiet, "no progress or tables");
  sub->callback([args, exit_code] { *exit_code = RunBench(*args); });
}

}  // namespace matfit::app
