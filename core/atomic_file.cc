#include "core/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>

namespace matfit {
namespace {

namespace fs = std::filesystem;

std::string UniqueSuffix() {
  static std::atomic<int> counter{0};
  return ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

}  // namespace

AtomicFile::AtomicFile(std::string final_path) : final_(std::move(final_path)) {
  const fs::path p(final_);
  const fs::path temp =
      p.parent_path() / ("." + p.stem().string() + UniqueSuffix() + p.extension().string());
  temp_ = temp.string();
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

Status AtomicFile::Commit() {
  std::error_code ec;
  fs::rename(temp_, final_, ec);
  if (ec) return IoError("cannot move '" + temp_ + "' to '" + final_ + "': " + ec.message());
  committed_ = true;
  return Status::Ok();
}

Status WriteFileAtomic(const std::string& path, const std::string& contents) {
  AtomicFile file(path);
  {
    std::ofstream out(file.temp_path(), std::ios::binary);
    if (!out) return IoError("cannot create '" + file.temp_path() + "'");
    out.write(contents.data(), std::streamsize(contents.size()));
    out.flush();
    if (!out) return IoError("writing '" + path + "' failed (disk full?)");
  }
  return file.Commit();
}

AtomicDir::AtomicDir(std::string final_path) : final_(std::move(final_path)) {
  while (!final_.empty() && final_.size() > 1 && final_.back() == '/') final_.pop_back();
  const fs::path p(final_);
  temp_ = (p.parent_path() / ("." + p.filename().string() + UniqueSuffix())).string();
}

AtomicDir::~AtomicDir() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

Status AtomicDir::Begin(bool overwrite) {
  overwrite_ = overwrite;
  std::error_code ec;
  if (fs::exists(final_, ec) && !overwrite)
    return InvalidArgument("output '" + final_ + "' already exists; choose another --out or " +
                           "pass --force to replace it");
  const fs::path parent = fs::path(temp_).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  fs::create_directories(temp_, ec);
  if (ec) return IoError("cannot create folder '" + temp_ + "': " + ec.message());
  return Status::Ok();
}

Status AtomicDir::Commit() {
  std::error_code ec;
  std::string old;
  if (fs::exists(final_, ec)) {
    if (!overwrite_) return InvalidArgument("output '" + final_ + "' appeared while writing");
    old = final_ + UniqueSuffix() + ".old";
    fs::rename(final_, old, ec);
    if (ec) return IoError("cannot move old '" + final_ + "' aside: " + ec.message());
  }
  fs::rename(temp_, final_, ec);
  if (ec) return IoError("cannot move '" + temp_ + "' to '" + final_ + "': " + ec.message());
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
  return Status::Ok();
}

}  // namespace matfit
