// The preview cache: PNG files under DATA/cache/previews/ID/KEY. Written atomically (a
// temporary in the same folder, fsync, rename), so a failed write (a full disk) leaves nothing
// behind; checked when read, so a file cut short is never served.
#pragma once

#include <optional>
#include <string>

#include "core/status.h"

namespace matfit::server {

class PreviewCache {
 public:
  // `root`: DATA/cache/previews. Temporaries of interrupted writes are removed.
  explicit PreviewCache(std::string root);

  // The cached PNG, or nullopt. A file that is not a whole PNG (empty, or cut short) is
  // deleted and reported as a miss.
  std::optional<std::string> Lookup(const std::string& id, const std::string& key);
  // Stores `png` for job `id` under `key`. On failure nothing is cached, and *err (when given)
  // receives the errno of the failed call (ENOSPC: the disk is full).
  Status Store(const std::string& id, const std::string& key, const std::string& png,
               int* err = nullptr);

 private:
  std::string root_;
};

// True when `bytes` is a whole PNG file: the signature first and the IEND chunk last.
bool IsWholePng(const std::string& bytes);

}  // namespace matfit::server
