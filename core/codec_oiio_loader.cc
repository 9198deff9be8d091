// Loads the OpenImageIO module (libmatfit_oiio.so, core/codec_oiio.cc) on first use.
// Search order: $MATFIT_OIIO_MODULE; beside the executable; ../lib/matfit/ from it; the build
// tree's copy (MATFIT_OIIO_MODULE_BUILD_PATH, set by CMake).
#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

#include "core/image_codec.h"

namespace matfit::codec {
namespace {

constexpr const char* kModuleName = "libmatfit_oiio.so";

std::vector<std::string> Candidates() {
  std::vector<std::string> paths;
  if (const char* env = std::getenv("MATFIT_OIIO_MODULE"); env && *env) paths.push_back(env);
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    paths.push_back((exe.parent_path() / kModuleName).string());
    paths.push_back((exe.parent_path() / ".." / "lib" / "matfit" / kModuleName).string());
  }
#ifdef MATFIT_OIIO_MODULE_BUILD_PATH
  paths.push_back(MATFIT_OIIO_MODULE_BUILD_PATH);
#endif
  return paths;
}

struct Loaded {
  Backend* backend = nullptr;
  std::string error;
};

Loaded Load() {
  Loaded r;
  std::string tried;
  for (const std::string& path : Candidates()) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
      tried += (tried.empty() ? "" : ", ") + path;
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* e = dlerror();
      r.error = "cannot load " + path + ": " + (e ? e : "unknown dlopen error");
      return r;
    }
    using Entry = Backend* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(handle, "matfit_oiio_backend"));
    if (!entry) {
      r.error = path + " has no matfit_oiio_backend entry point (a stale build?)";
      return r;
    }
    r.backend = entry();  // the module stays loaded for the life of the process
    return r;
  }
  r.error = std::string("the OpenImageIO module ") + kModuleName +
            " was not found (looked at: " + tried +
            "); set MATFIT_OIIO_MODULE to its path or rebuild (scripts/build.sh)";
  return r;
}

}  // namespace

Backend* OpenImageIo(std::string* error) {
  static std::once_flag once;
  static Loaded loaded;
  std::call_once(once, [] { loaded = Load(); });
  if (!loaded.backend && error) *error = loaded.error;
  return loaded.backend;
}

std::unique_ptr<Reader> OpenAny(const std::string& path, std::string* error) {
  error->clear();
  if (auto r = Native().Open(path, error); r || !error->empty()) return r;
  Backend* oiio = OpenImageIo(error);
  if (!oiio) return nullptr;
  return oiio->Open(path, error);
}

}  // namespace matfit::codec
