// matfit info: layout, images, light distribution, conditioning, warnings.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "app/commands.h"
#include "core/dataset/dataset.h"
#include "core/dataset/info.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "fit/diagnostics.h"

namespace matfit::app {
namespace {

struct InfoArgs {
  std::string path, layout = "auto", view, color_space = "auto", crop;
  bool json = false, quiet = false;
  int threads = 0;
};

int RunInfo(const InfoArgs& a) {
  ReadOptions ro;
  if (int rc = ApplyReadArgs("info", a.layout, a.view, a.color_space, a.crop, &ro)) return rc;
  SetNumThreads(a.threads);
  std::string reason;
  if (ro.layout == Layout::kAuto) {
    auto detected = DetectLayout(a.path, &reason);
    if (!detected.ok()) return Fail("info", detected.status().message().c_str());
    ro.layout = *detected;
  }
  ProgressReporter progress(
      "reading", stderr,
      a.quiet ? ProgressReporter::Style::kQuiet : ProgressReporter::Style::kAuto);
  ro.progress = progress.Callback();
  auto stack = ReadDataset(a.path, ro);
  if (!stack.ok()) return Fail("info", stack.status().message().c_str());
  // The γ check a fit makes (fit/diagnostics.h): info says it before anything is fitted, and
  // with --color-space auto reads the stack as the fit would.
  fit::StackDiagnostics diag = fit::DiagnoseStack(*stack);
  if (ro.color_space == ColorSpaceChoice::kAuto) (void)fit::ResolveToneCurve(&*stack, &diag);
  DatasetInfo info = ComputeDatasetInfo(*stack);
  info.tone_curve = fit::DescribeToneCurve(diag);
  info.tone_verdict = fit::ToneVerdictName(diag.verdict);
  for (auto& w : diag.warnings) info.warnings.push_back(std::move(w));
  info.detection_reason = reason;
  const std::string text = a.json ? DatasetInfoJson(info) : FormatDatasetInfo(info);
  std::fputs(text.c_str(), stdout);
  return 0;
}

}  // namespace

void RegisterInfo(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* sub = app.add_subcommand("info",
                                     "Describe a dataset: layout, images, lights, "
                                     "conditioning, colour space, warnings");
  sub->add_option("DIR", args->path, "dataset folder (or .lp file)")->required();
  sub->add_option("--layout", args->layout, "auto, bonn, utia, lp, diligent, lights-txt")
      ->capture_default_str();
  sub->add_option("--view", args->view,
                  "BTF view THETA,PHI in degrees (default: most frontal), or all");
  sub->add_option("--crop", args->crop, kCropHelp);
  sub->add_option("--color-space", args->color_space, "auto, srgb or linear")
      ->capture_default_str();
  sub->add_flag("--json", args->json, "print JSON instead of text");
  sub->add_option("--threads", args->threads, kThreadsHelp)->capture_default_str();
  sub->add_flag("--quiet", args->quiet, "no progress output");
  sub->callback([args, exit_code] { *exit_code = RunInfo(*args); });
}

}  // namespace matfit::app
