// Atomic replacement of files and folders: write under a temporary name in the same folder,
// then rename over the final name, so readers never see a half-written result.
#pragma once

#include <string>
#include <string_view>

#include "core/status.h"

namespace matfit {

class AtomicFile {
 public:
  // The temporary keeps the final extension so that format-by-extension writers work.
  explicit AtomicFile(std::string final_path);
  ~AtomicFile();  // removes the temporary unless committed
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& temp_path() const { return temp_; }
  Status Commit();  // rename(temp, final)

 private:
  std::string final_, temp_;
  bool committed_ = false;
};

// Writes `contents` to `path` atomically.
Status WriteFileAtomic(const std::string& path, std::string_view contents);

// A folder built under a temporary name beside `final_path`, then moved into place. The
// finished folder carries matfit's output marker (core/output_marker.h) naming `kind`
// ("pack", "dataset", ...), so that a later --force can tell it from a user's folder.
class AtomicDir {
 public:
  AtomicDir(std::string final_path, std::string kind);
  ~AtomicDir();  // removes the temporary tree unless committed
  AtomicDir(const AtomicDir&) = delete;
  AtomicDir& operator=(const AtomicDir&) = delete;

  // Creates the temporary folder. Fails if `final_path` exists and !overwrite, or if it
  // exists and is not something matfit wrote (CheckReplaceable).
  Status Begin(bool overwrite);
  const std::string& temp_path() const { return temp_; }
  // Writes the marker listing the temporary tree's files (Commit does it when not done yet;
  // call it first when the tree is packed some other way, e.g. zipped).
  Status WriteMarker();
  // Moves the finished tree to the final name (replacing an old one when overwrite was set).
  Status Commit();

 private:
  std::string final_, kind_, temp_;
  bool marked_ = false;
  bool overwrite_ = false, committed_ = false;
};

}  // namespace matfit
