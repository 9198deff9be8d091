// Subcommands of the `matfit` binary. Each Register* adds its CLI11 subcommand; the
// callbacks set the process exit code through *exit_code.
#pragma once

#include <string>

#include "core/dataset/dataset.h"

namespace CLI {
class App;
}

namespace matfit::app {

void RegisterSynth(CLI::App& app, int* exit_code);
void RegisterInfo(CLI::App& app, int* exit_code);
void RegisterFit(CLI::App& app, int* exit_code);
void RegisterRender(CLI::App& app, int* exit_code);
void RegisterLeaf(CLI::App& app, int* exit_code);
void RegisterServe(CLI::App& app, int* exit_code);
void RegisterCapture(CLI::App& app, int* exit_code);  // capture, calibrate-lights, devices
void RegisterBench(CLI::App& app, int* exit_code);

// Shared helpers.
bool ParseViewArg(const char* text, double* theta, double* phi);  // "THETA,PHI" in degrees
int Fail(const char* command, const char* message);  // prints "matfit CMD: error: ..." → 1
// Parses --layout, --view THETA,PHI and --color-space into *read; 0, or Fail()'s code.
int ApplyReadArgs(const char* command, const std::string& layout, const std::string& view,
                  const std::string& color_space, ReadOptions* read);

}  // namespace matfit::app
