// Subcommands of the `matfit` binary. Each Register* adds its CLI11 subcommand; the
// callbacks set the process exit code through *exit_code.
#pragma once

namespace CLI {
class App;
}

namespace matfit::app {

void RegisterSynth(CLI::App& app, int* exit_code);
void RegisterInfo(CLI::App& app, int* exit_code);
void RegisterFit(CLI::App& app, int* exit_code);

// Shared helpers.
bool ParseViewArg(const char* text, double* theta, double* phi);  // "THETA,PHI" in degrees
int Fail(const char* command, const char* message);  // prints "matfit CMD: error: ..." → 1

}  // namespace matfit::app
