#include "server/preview_cache.h"

#include <fcntl.h>
#include <unistd.h>

#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace matfit::server {
namespace {

namespace fs = std::filesystem;

bool IsTemporaryName(const std::string& name) {
  return !name.empty() && name[0] == '.' && name.find(".tmp-") != std::string::npos;
}

// Writes `bytes` to `path` and makes them durable; errno of the failed call, or 0.
int WriteDurably(const std::string& path, const std::string& bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return errno;
  for (size_t at = 0; at < bytes.size();) {
    const ssize_t n = ::write(fd, bytes.data() + at, bytes.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      return err;
    }
    at += size_t(n);
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    return err;
  }
  return ::close(fd) != 0 ? errno : 0;
}

}  // namespace

bool IsWholePng(const std::string& b) {
  static const std::string kSignature = "\x89PNG\r\n\x1a\n";
  static const std::string kEnd("\0\0\0\0IEND\xae\x42\x60\x82", 12);
  return b.size() >= kSignature.size() + kEnd.size() && b.compare(0, 8, kSignature) == 0 &&
         b.compare(b.size() - kEnd.size(), kEnd.size(), kEnd) == 0;
}

PreviewCache::PreviewCache(std::string root, int64_t max_bytes)
    : root_(std::move(root)), max_bytes_(max_bytes) {
  struct Found {
    std::string name;
    int64_t bytes;
    fs::file_time_type used;
  };
  std::vector<Found> found;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root_, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    std::error_code e;
    if (!it->is_regular_file(e)) continue;
    if (IsTemporaryName(it->path().filename().string())) {
      fs::remove(it->path(), e);
      continue;
    }
    const auto size = it->file_size(e);
    const auto used = it->last_write_time(e);
    if (!e)
      found.push_back({fs::relative(it->path(), root_, e).generic_string(), int64_t(size), used});
  }
  std::sort(found.begin(), found.end(),
            [](const Found& a, const Found& b) { return a.used < b.used; });
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& f : found) UseLocked(f.name, f.bytes);
}

void PreviewCache::UseLocked(const std::string& name, int64_t bytes) {
  EraseLocked(name);
  lru_.push_back({name, bytes});
  index_[name] = std::prev(lru_.end());
  total_ += bytes;
  EvictLocked();
}

void PreviewCache::EvictLocked() {
  while (total_ > max_bytes_ && !lru_.empty()) {
    const std::string name = lru_.front().name;
    std::error_code ec;
    fs::remove(root_ + "/" + name, ec);
    EraseLocked(name);
  }
}

void PreviewCache::EraseLocked(const std::string& name) {
  const auto it = index_.find(name);
  if (it == index_.end()) return;
  total_ -= it->second->bytes;
  lru_.erase(it->second);
  index_.erase(it);
}

void PreviewCache::ForgetJob(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string prefix = id + "/";
  std::vector<std::string> names;
  for (const auto& e : lru_)
    if (e.name.rfind(prefix, 0) == 0) names.push_back(e.name);
  for (const auto& n : names) EraseLocked(n);
}

int64_t PreviewCache::bytes() {
  std::lock_guard<std::mutex> lock(mutex_);
  return total_;
}

std::optional<std::string> PreviewCache::Lookup(const std::string& id, const std::string& key) {
  const std::string path = root_ + "/" + id + "/" + key;
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::stringstream s;
  s << in.rdbuf();
  std::string bytes = s.str();
  const std::string name = id + "/" + key;
  if (!IsWholePng(bytes)) {  // a write cut short (or emptied): never served, rendered again
    std::error_code ec;
    fs::remove(path, ec);
    std::lock_guard<std::mutex> lock(mutex_);
    EraseLocked(name);
    return std::nullopt;
  }
  ::utimensat(AT_FDCWD, path.c_str(), nullptr, 0);  // the use order, for the next start
  std::lock_guard<std::mutex> lock(mutex_);
  UseLocked(name, int64_t(bytes.size()));
  return bytes;
}

Status PreviewCache::Store(const std::string& id, const std::string& key, const std::string& png,
                           int* err) {
  static std::atomic<int> counter{0};
  const std::string dir = root_ + "/" + id, path = dir + "/" + key;
  const std::string temp =
      dir + "/." + key + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  auto fail = [&](int e, const std::string& what) {
    std::error_code ec;
    fs::remove(temp, ec);
    if (err) *err = e;
    return IoError("caching the preview failed: " + what + ": " + std::strerror(e));
  };
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(ec.value(), "cannot create its folder");
  if (const int e = WriteDurably(temp, png); e != 0) return fail(e, "writing it");
  if (::rename(temp.c_str(), path.c_str()) != 0) return fail(errno, "renaming it into place");
  if (err) *err = 0;
  std::lock_guard<std::mutex> lock(mutex_);
  UseLocked(id + "/" + key, int64_t(png.size()));  // evicts the oldest (this one if too big)
  return Status::Ok();
}

}  // namespace matfit::server
