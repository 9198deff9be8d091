// Subcommands of the `matfit` binary. Each Register* adds its CLI11 subcommand; the
// callbacks set the process exit code through *exit_code.
#pragma once

#include <optional>
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
void RegisterTokens(CLI::App& app, int* exit_code);           // a cluster's bearer tokens
void RegisterCapture(CLI::App& app, int* exit_code);          // capture, calibrate-lights, devices
void RegisterCalibrateLights(CLI::App& app, int* exit_code);  // via RegisterCapture
void RegisterBench(CLI::App& app, int* exit_code);

// Shared help texts: the same flag means the same thing in every subcommand.
inline constexpr char kForceHelp[] =
    "replace --out if matfit wrote it (anything else is refused, never deleted)";
inline constexpr char kThreadsHelp[] = "worker threads (0 = all cores)";
// Options required only without another one say so in --help ("REQUIRED" as CLI11 prints it).
inline std::string RequiredUnless(const std::string& other) {
  return "[REQUIRED unless " + other + "]";
}

// `matfit --help`'s first line.
inline constexpr char kAppDescription[] =
    "matfit: fit materials (normals, albedo, specular, translucency) to multi-light measurements";
// Parses the command line and runs the chosen subcommand: its exit code, or CLI11's for a bad
// command line; an exception that escapes a subcommand is printed and gives 1.
int ParseAndRun(CLI::App& app, int argc, char** argv, const int& exit_code);

// Shared helpers.
bool ParseViewArg(const char* text, double* theta, double* phi);  // "THETA,PHI" in degrees
int Fail(const char* command, const char* message);  // prints "matfit CMD: error: ..." → 1
// Parses --layout, --view THETA,PHI, --color-space and --crop X,Y,W,H into *read; 0, or
// Fail()'s code.
int ApplyReadArgs(const char* command, const std::string& layout, const std::string& view,
                  const std::string& color_space, const std::string& crop, ReadOptions* read);
// Parses --crop X,Y,W,H (empty: none) into *out; 0, or Fail()'s code.
int ApplyCropArg(const char* command, const std::string& crop, std::optional<CropRect>* out);
inline constexpr char kCropHelp[] =
    "read only this region of every image: X,Y,WIDTH,HEIGHT in pixels (e.g. 100,50,640,480)";

}  // namespace matfit::app
