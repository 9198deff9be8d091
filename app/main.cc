// matfit-full: every subcommand of matfit (`matfit --help` lists them). The `matfit` users run
// (app/main_lean.cc) runs fit and info itself and hands every other command to this binary.
#include <CLI/CLI.hpp>
#include <string>

#include "app/commands.h"
#include "core/large_page_allocator.h"
#include "core/version.h"

int main(int argc, char** argv) {
  matfit::TuneAllocatorForImageBuffers();
  CLI::App app{matfit::app::kAppDescription};
  app.set_version_flag("--version", std::string("matfit ") + matfit::kMatfitVersion);
  app.require_subcommand(1);
  int exit_code = 0;
  matfit::app::RegisterSynth(app, &exit_code);
  matfit::app::RegisterInfo(app, &exit_code);
  matfit::app::RegisterFit(app, &exit_code);
  matfit::app::RegisterRender(app, &exit_code);
  matfit::app::RegisterLeaf(app, &exit_code);
  matfit::app::RegisterServe(app, &exit_code);
  matfit::app::RegisterTokens(app, &exit_code);
  matfit::app::RegisterCapture(app, &exit_code);
  matfit::app::RegisterBench(app, &exit_code);
  return matfit::app::ParseAndRun(app, argc, argv, exit_code);
}
