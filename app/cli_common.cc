// Helpers shared by the subcommands of both binaries (app/commands.h).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>
#include <string>

#include "app/commands.h"

namespace matfit::app {

bool ParseViewArg(const char* text, double* theta, double* phi) {
  char* end = nullptr;
  *theta = std::strtod(text, &end);
  if (end == text || *end != ',') return false;
  const char* p = end + 1;
  *phi = std::strtod(p, &end);
  return end != p && *end == '\0';
}

int Fail(const char* command, const char* message) {
  std::fprintf(stderr, "matfit %s: error: %s\n", command, message);
  return 1;
}

int ApplyCropArg(const char* command, const std::string& crop, std::optional<CropRect>* out) {
  if (crop.empty()) return 0;
  CropRect c;
  if (!ParseCrop(crop, &c))
    return Fail(command, ("--crop '" + crop +
                          "' must be X,Y,WIDTH,HEIGHT in pixels (whole numbers, width and height "
                          "> 0), e.g. 100,50,640,480")
                             .c_str());
  *out = c;
  return 0;
}

int ApplyReadArgs(const char* command, const std::string& layout, const std::string& view,
                  const std::string& color_space, const std::string& crop, ReadOptions* read) {
  if (int rc = ApplyCropArg(command, crop, &read->crop)) return rc;
  if (!ParseLayout(layout, &read->layout))
    return Fail(command, ("--layout '" + layout +
                          "' is not one of auto, bonn, utia, lp, diligent, lights-txt")
                             .c_str());
  if (view == "all") {
    read->all_views = true;
  } else if (!view.empty()) {
    ViewAngles v;
    if (!ParseViewArg(view.c_str(), &v.theta_deg, &v.phi_deg))
      return Fail(command,
                  ("--view '" + view + "' must be THETA,PHI in degrees (e.g. 0,0) or all").c_str());
    read->view = v;
  }
  if (!ParseColorSpaceChoice(color_space, &read->color_space))
    return Fail(command,
                ("--color-space '" + color_space + "' must be auto, srgb or linear").c_str());
  return 0;
}

int ParseAndRun(CLI::App& app, int argc, char** argv, const int& exit_code) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    // Last line of defence: nothing a user's file does may end in a crash.
    std::fprintf(stderr, "matfit: error: %s\n", e.what());
    return 1;
  }
  return exit_code;
}

}  // namespace matfit::app
