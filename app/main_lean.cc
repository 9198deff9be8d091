// matfit: the command users run. `fit` and `info` run in this binary, which links only what they
// need (core and fit: 17 shared libraries, ~11 ms to load on the 2-core test VM); every other
// subcommand — and `fit` under an MPI launcher — runs in matfit-full beside it, which links all
// 79 (the server's PostgreSQL, HTTP and TLS, EGL, OpenCV, MPI, libusb: ~46 ms before main on
// the same VM, docs/benchmarks.md). The hand-over is an exec: the same process, arguments and
// environment, so exit codes, signals and `/usr/bin/time` figures are the command's own.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>

#include "app/commands.h"
#include "core/large_page_allocator.h"
#include "core/version.h"
#include "mpi/session.h"

namespace {

// Replaces this process with matfit-full from this binary's folder; returns only on failure.
int RunInFullBinary(char** argv) {
  std::string self(4096, '\0');
  const ssize_t n = readlink("/proc/self/exe", self.data(), self.size() - 1);
  if (n <= 0) {
    std::fprintf(stderr, "matfit: error: cannot find this executable (/proc/self/exe: %s)\n",
                 std::strerror(errno));
    return 1;
  }
  self.resize(size_t(n));
  const std::string full = self.substr(0, self.rfind('/') + 1) + "matfit-full";
  execv(full.c_str(), argv);
  std::fprintf(stderr,
               "matfit: error: this command runs in '%s', which cannot be started (%s); build "
               "every target (scripts/build.sh) or keep matfit-full beside matfit\n",
               full.c_str(), std::strerror(errno));
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string_view command = argc > 1 ? argv[1] : "";
  const bool here = command == "info" || command == "--version" ||
                    (command == "fit" && !matfit::mpi::LaunchedByMpi());
  if (!here) return RunInFullBinary(argv);
  matfit::TuneAllocatorForImageBuffers();
  CLI::App app{matfit::app::kAppDescription};
  app.set_version_flag("--version", std::string("matfit ") + matfit::kMatfitVersion);
  app.require_subcommand(1);
  int exit_code = 0;
  matfit::app::RegisterInfo(app, &exit_code);
  matfit::app::RegisterFit(app, &exit_code);
  return matfit::app::ParseAndRun(app, argc, argv, exit_code);
}
