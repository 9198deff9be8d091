// Uploaded dataset archives (server/archive.cc ExtractArchive): zip, tar and tar.gz bytes are
// the input; small limits so that the limit paths are reached too.
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "fuzz/fuzz_util.h"
#include "server/archive.h"

using namespace matfit;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = fuzz::ScratchDir();
  const std::string archive = dir + "/upload.bin", dest = dir + "/unpacked";
  fuzz::WriteBytes(archive, data, size);
  std::error_code ec;
  std::filesystem::remove_all(dest, ec);
  server::ArchiveLimits limits;
  limits.max_entries = 64, limits.max_folders = 16;
  limits.max_unpacked_bytes = int64_t(8) << 20, limits.min_unpack_budget = int64_t(1) << 20;
  server::ArchiveProblem problem = server::ArchiveProblem::kNone;
  auto r = server::ExtractArchive(archive, dest, limits, &problem);
  // Either a result inside dest or an error with its kind, and dest gone.
  if (r.ok() == (problem != server::ArchiveProblem::kNone)) std::abort();
  if (!r.ok() && std::filesystem::exists(dest)) std::abort();
  std::filesystem::remove_all(dest, ec);
  return 0;
}
