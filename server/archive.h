// Safe extraction of uploaded dataset archives (.zip, .tar, .tar.gz; recognised by content, not by
// name). Hostile archives are refused with a message naming the entry: absolute paths, `..`
// components, links, device files, too many entries or too many unpacked bytes (zip bombs:
// counted on the bytes actually written, not on the sizes the headers claim).
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"

namespace matfit::server {

struct ArchiveLimits {
  int64_t max_entries = 20000;                    // files + folders
  int64_t max_unpacked_bytes = int64_t(8) << 30;  // sum over files, 8 GiB
  bool Check(std::string* why) const;
};

enum class ArchiveProblem {
  kNone,
  kMalformed,    // not a zip/tar(.gz), or corrupt
  kUnsafeEntry,  // absolute path, `..`, link, device, bad name
  kLimit,        // entry count or unpacked size over the limits
};

struct ArchiveResult {
  int64_t entries = 0, bytes = 0;
  std::string dataset_root;  // `dest`, or its only top-level folder when the archive has one
};

// Extracts `archive` into the folder `dest`, which must not exist yet (it is created). On any
// error `dest` is removed again and *problem says which kind of error it was. macOS metadata
// (`__MACOSX/`, `._*`) is skipped.
StatusOr<ArchiveResult> ExtractArchive(const std::string& archive, const std::string& dest,
                                       const ArchiveLimits& limits, ArchiveProblem* problem);

}  // namespace matfit::server
