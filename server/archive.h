// Safe extraction of uploaded dataset archives (.zip, .tar, .tar.gz; recognised by content, not by
// name). Hostile archives are refused with a message naming the entry: absolute paths, `..`
// components, links, device files, too many entries or folders, or too many unpacked bytes (zip
// bombs: counted on the bytes actually written, not on the sizes the headers claim; the budget
// grows with the archive's size up to an absolute cap).
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"

namespace matfit::server {

struct ArchiveLimits {
  int64_t max_entries = 20000;                    // files + folders
  int64_t max_folders = 256;                      // folders, the implied parents of files included
  int64_t max_unpacked_bytes = int64_t(8) << 30;  // sum over files, 8 GiB
  // Relative budget: at most max_unpack_ratio × the archive's size is unpacked, but never less
  // than min_unpack_budget (a tiny archive of a small dataset still unpacks); 0 = off. The
  // absolute max_unpacked_bytes applies as well.
  int64_t max_unpack_ratio = 100;
  int64_t min_unpack_budget = int64_t(64) << 20;  // 64 MiB
  bool Check(std::string* why) const;
  // The bytes an archive of `archive_bytes` may unpack to.
  int64_t UnpackBudget(int64_t archive_bytes) const;
};

enum class ArchiveProblem {
  kNone,
  kMalformed,    // not a zip/tar(.gz), or corrupt
  kUnsafeEntry,  // absolute path, `..`, link, device, bad name
  kLimit,        // entry count, folder count or unpacked size over the limits
  kNoSpace,      // the disk (or the quota) filled while unpacking
};

struct ArchiveResult {
  int64_t entries = 0, bytes = 0;
  std::string dataset_root;  // `dest`, or its only top-level folder when the archive has one
};

// Extracts `archive` into the folder `dest`, which must not exist yet (it is created). On any
// error `dest` is removed again and *problem says which kind of error it was. macOS metadata
// (`__MACOSX/`, `._*`) is skipped, and so is the entry `./` (the root itself, as `tar -C dir .`
// writes it).
StatusOr<ArchiveResult> ExtractArchive(const std::string& archive, const std::string& dest,
                                       const ArchiveLimits& limits, ArchiveProblem* problem);

}  // namespace matfit::server
