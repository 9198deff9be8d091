// The preview cache: PNG files under DATA/cache/previews/ID/KEY. Written atomically (a
// temporary in the same folder, fsync, rename), so a failed write (a full disk) leaves nothing
// behind; checked when read, so a file cut short is never served. Bounded: its files never
// total more than max_bytes; the least recently used go first (use order survives restarts
// through the files' modification times).
#pragma once

#include <cstdint>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "core/status.h"

namespace matfit::server {

class PreviewCache {
 public:
  // `root`: DATA/cache/previews. Temporaries of interrupted writes are removed; the files
  // there are counted (oldest first) and trimmed to max_bytes.
  PreviewCache(std::string root, int64_t max_bytes);

  // The cached PNG, or nullopt. A file that is not a whole PNG (empty, or cut short) is
  // deleted and reported as a miss.
  std::optional<std::string> Lookup(const std::string& id, const std::string& key);
  // Stores `png` for job `id` under `key`. On failure nothing is cached, and *err (when given)
  // receives the errno of the failed call (ENOSPC: the disk is full).
  // A preview larger than max_bytes is not kept (Ok: the caller serves it anyway).
  Status Store(const std::string& id, const std::string& key, const std::string& png,
               int* err = nullptr);
  // Forgets the entries of a deleted job (its folder is removed by the caller).
  void ForgetJob(const std::string& id);
  int64_t bytes();  // total size of the cached files

 private:
  struct Entry {
    std::string name;  // "ID/KEY"
    int64_t bytes = 0;
  };
  // Under mutex_: (re)inserts `name` as the most recently used, then evicts the least
  // recently used entries until the total fits.
  void UseLocked(const std::string& name, int64_t bytes);
  void EvictLocked();
  void EraseLocked(const std::string& name);

  const std::string root_;
  const int64_t max_bytes_;
  std::mutex mutex_;
  std::list<Entry> lru_;  // least recently used first
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
  int64_t total_ = 0;
};

// True when `bytes` is a whole PNG file: the signature first and the IEND chunk last.
bool IsWholePng(const std::string& bytes);

}  // namespace matfit::server
