#include "core/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/output_marker.h"

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

Status WriteFileAtomic(const std::string& path, std::string_view contents) {
  AtomicFile file(path);
  const int fd = ::open(file.temp_path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return IoError("cannot create '" + file.temp_path() + "': " + std::strerror(errno));
  for (size_t at = 0; at < contents.size();) {
    const ssize_t n = ::write(fd, contents.data() + at, contents.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      return IoError("writing '" + path + "' failed: " + std::strerror(err));
    }
    at += size_t(n);
  }
  if (::close(fd) != 0) return IoError("writing '" + path + "' failed: " + std::strerror(errno));
  return file.Commit();
}

AtomicDir::AtomicDir(std::string final_path, std::string kind)
    : final_(std::move(final_path)), kind_(std::move(kind)) {
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
  MATFIT_RETURN_IF_ERROR(CheckOutput(final_, overwrite));
  const fs::path parent = fs::path(temp_).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  fs::create_directories(temp_, ec);
  if (ec) return IoError("cannot create folder '" + temp_ + "': " + ec.message());
  return Status::Ok();
}

Status AtomicDir::WriteMarker() {
  MATFIT_RETURN_IF_ERROR(WriteOutputMarker(temp_, kind_));
  marked_ = true;
  return Status::Ok();
}

Status AtomicDir::Commit() {
  if (!marked_) MATFIT_RETURN_IF_ERROR(WriteMarker());
  std::error_code ec;
  std::string old;
  if (fs::exists(fs::symlink_status(final_, ec))) {
    if (!overwrite_) return InvalidArgument("output '" + final_ + "' appeared while writing");
    MATFIT_RETURN_IF_ERROR(CheckReplaceable(final_));  // it may have changed since Begin
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
