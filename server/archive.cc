#include "server/archive.h"

#include <archive.h>
#include <archive_entry.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <set>
#include <vector>

#include "server/text.h"

namespace matfit::server {
namespace {

// libarchive's message for the last error; it may be NULL (e.g. a truncated zip), and a NULL
// appended to a std::string crashed the server (found by fuzz/archive_fuzzer).
std::string ArchiveError(struct archive* a) {
  const char* m = archive_error_string(a);
  return m && *m ? m : "libarchive gave no reason";
}

namespace fs = std::filesystem;

using ArchivePtr = std::unique_ptr<struct archive, int (*)(struct archive*)>;

// Splits an entry name into safe components, or explains why it is unsafe. `.` components are
// dropped, so `./` (the root itself) gives no components and `./a` gives {a}.
bool SafeComponents(const std::string& name, std::vector<std::string>* parts, std::string* why) {
  if (name.empty()) return *why = "has an empty name", false;
  // Names end up in JSON (job records, messages): UTF-8 only.
  if (!IsUtf8(name))
    return *why = "has a name that is not UTF-8 (re-create the archive with UTF-8 names)", false;
  if (name.find('\0') != std::string::npos) return *why = "has a NUL byte in its name", false;
  if (name.find('\\') != std::string::npos)
    return *why = "uses '\\' in its name; archive names must use '/'", false;
  if (name[0] == '/') return *why = "has an absolute path", false;
  if (name.size() > 1 && name[1] == ':') return *why = "has a drive-letter path", false;
  size_t start = 0;
  while (start <= name.size()) {
    size_t end = name.find('/', start);
    if (end == std::string::npos) end = name.size();
    const std::string c = name.substr(start, end - start);
    if (c == "..") return *why = "has a '..' component that would leave the dataset folder", false;
    if (!c.empty() && c != ".") parts->push_back(c);
    start = end + 1;
  }
  return true;
}

// A disk (or quota) that filled: 507 for the client, not a server fault.
bool IsNoSpace(int err) { return err == ENOSPC || err == EDQUOT; }

std::string Size(int64_t bytes) {
  return bytes >= (int64_t(1) << 20) ? std::to_string(bytes >> 20) + " MiB"
                                     : std::to_string(std::max<int64_t>(1, bytes >> 10)) + " KiB";
}

bool IsMacMetadata(const std::vector<std::string>& parts) {
  return parts.front() == "__MACOSX" || parts.back().rfind("._", 0) == 0 ||
         parts.back() == ".DS_Store";
}

}  // namespace

bool ArchiveLimits::Check(std::string* why) const {
  if (max_entries < 1) return *why = "archive entry limit must be ≥ 1", false;
  if (max_folders < 1) return *why = "archive folder limit (--max-folders) must be ≥ 1", false;
  if (max_unpacked_bytes < 1) return *why = "archive unpacked-size limit must be ≥ 1 byte", false;
  if (max_unpack_ratio < 0)
    return *why = "archive unpack ratio (--max-unpack-ratio) must be ≥ 1, or 0 for none", false;
  if (max_unpack_ratio > 0 && min_unpack_budget < 1)
    return *why = "the smallest unpack budget must be ≥ 1 byte", false;
  return true;
}

int64_t ArchiveLimits::UnpackBudget(int64_t archive_bytes) const {
  if (max_unpack_ratio <= 0) return max_unpacked_bytes;
  const int64_t big = std::numeric_limits<int64_t>::max();
  const int64_t relative = archive_bytes > big / max_unpack_ratio
                               ? big
                               : std::max<int64_t>(0, archive_bytes) * max_unpack_ratio;
  return std::min(max_unpacked_bytes, std::max(min_unpack_budget, relative));
}

StatusOr<ArchiveResult> ExtractArchive(const std::string& archive_path, const std::string& dest,
                                       const ArchiveLimits& limits, ArchiveProblem* problem) {
  *problem = ArchiveProblem::kNone;
  std::error_code ec;
  // Messages name archive entries, never server paths (they reach the client).
  if (fs::exists(dest, ec)) return InvalidArgument("the extraction folder exists already");
  if (!fs::create_directories(dest, ec)) {
    if (IsNoSpace(ec.value())) *problem = ArchiveProblem::kNoSpace;
    return IoError("cannot create the extraction folder: " + ec.message());
  }
  bool keep = false;
  struct Cleanup {
    const std::string& dir;
    bool& keep;
    ~Cleanup() {
      std::error_code e;
      if (!keep) fs::remove_all(dir, e);
    }
  } cleanup{dest, keep};
  auto fail = [&](ArchiveProblem p, std::string message) -> Status {
    *problem = p;
    return p == ArchiveProblem::kNone || p == ArchiveProblem::kNoSpace
               ? IoError(std::move(message))
               : InvalidArgument(std::move(message));
  };
  ArchiveResult result;
  auto no_space = [&](const std::string& name) {
    return fail(ArchiveProblem::kNoSpace,
                "the server ran out of disk space while unpacking the archive (at entry '" +
                    Printable(name) + "', " + Size(result.bytes) +
                    " unpacked); nothing was kept. Retry later, or ask the operator to free "
                    "space");
  };
  const auto size = fs::file_size(archive_path, ec);
  const int64_t archive_bytes = ec ? 0 : int64_t(size);
  const int64_t budget = limits.UnpackBudget(archive_bytes);
  const std::string over_budget =
      budget < limits.max_unpacked_bytes
          ? "the archive unpacks to more than " + Size(budget) + ": the server unpacks at most " +
                std::to_string(limits.max_unpack_ratio) + " times the upload's size (" +
                Size(archive_bytes) + "), and at least " + Size(limits.min_unpack_budget) +
                " (--max-unpack-ratio)"
          : "the archive unpacks to more than " + Size(limits.max_unpacked_bytes) +
                " (the server's limit)";
  std::set<std::string> folders;  // relative paths of the folders the archive makes

  ArchivePtr a(archive_read_new(), archive_read_free);
  archive_read_support_filter_gzip(a.get());
  archive_read_support_filter_bzip2(a.get());
  archive_read_support_filter_xz(a.get());
  archive_read_support_format_zip(a.get());
  archive_read_support_format_tar(a.get());
  archive_read_support_format_gnutar(a.get());
  if (archive_read_open_filename(a.get(), archive_path.c_str(), 1 << 16) != ARCHIVE_OK)
    return fail(ArchiveProblem::kMalformed,
                std::string("the upload is not a .zip, .tar or .tar.gz archive (") +
                    ArchiveError(a.get()) + ")");
  result.dataset_root = dest;
  std::vector<char> buf(1 << 16);
  for (;;) {
    struct archive_entry* e = nullptr;
    const int r = archive_read_next_header(a.get(), &e);
    if (r == ARCHIVE_EOF) break;
    if (r != ARCHIVE_OK && r != ARCHIVE_WARN)
      return fail(ArchiveProblem::kMalformed,
                  std::string("the archive is corrupt: ") + ArchiveError(a.get()));
    const char* raw = archive_entry_pathname(e);
    const std::string name = raw ? raw : "";
    if (++result.entries > limits.max_entries)
      return fail(ArchiveProblem::kLimit, "the archive has more than " +
                                              std::to_string(limits.max_entries) +
                                              " entries (the server's limit)");
    std::vector<std::string> parts;
    std::string why;
    if (!SafeComponents(name, &parts, &why))
      return fail(ArchiveProblem::kUnsafeEntry, "archive entry '" + Printable(name) + "' " + why);
    const auto type = archive_entry_filetype(e);
    if (archive_entry_hardlink(e) || type == AE_IFLNK)
      return fail(ArchiveProblem::kUnsafeEntry,
                  "archive entry '" + Printable(name) +
                      "' is a link; links are refused (archive the files themselves)");
    if (type != AE_IFREG && type != AE_IFDIR)
      return fail(ArchiveProblem::kUnsafeEntry,
                  "archive entry '" + Printable(name) + "' is neither a file nor a folder");
    if (parts.empty()) {
      if (type == AE_IFDIR) continue;  // `./`: the extraction folder itself
      return fail(ArchiveProblem::kUnsafeEntry,
                  "archive entry '" + Printable(name) + "' names no file");
    }
    if (IsMacMetadata(parts)) continue;
    // Folders cost the disk far more than their bytes (an inode each): count them, the parents
    // a file implies included, before any is made.
    std::string rel;
    const size_t folder_parts = type == AE_IFDIR ? parts.size() : parts.size() - 1;
    for (size_t k = 0; k < folder_parts; ++k) {
      rel += (k ? "/" : "") + parts[k];
      folders.insert(rel);
    }
    if (int64_t(folders.size()) > limits.max_folders)
      return fail(ArchiveProblem::kLimit, "the archive has more than " +
                                              std::to_string(limits.max_folders) +
                                              " folders (the server's limit, --max-folders)");
    fs::path out(dest);
    for (const auto& p : parts) out /= p;
    if (type == AE_IFDIR) {
      fs::create_directories(out, ec);
      if (ec && IsNoSpace(ec.value())) return no_space(name);
      if (ec)
        return fail(ArchiveProblem::kUnsafeEntry,
                    "archive entry '" + Printable(name) + "' conflicts with an earlier entry");
      continue;
    }
    fs::create_directories(out.parent_path(), ec);
    if (ec && IsNoSpace(ec.value())) return no_space(name);
    if (ec)
      return fail(ArchiveProblem::kUnsafeEntry, "archive entry '" + Printable(name) +
                                                    "' cannot be placed (" + ec.message() + ")");
    // O_EXCL | O_NOFOLLOW: never write through an existing file or link (duplicate entries).
    const int fd = ::open(out.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0 && IsNoSpace(errno)) return no_space(name);
    if (fd < 0)
      return fail(ArchiveProblem::kUnsafeEntry,
                  "archive entry '" + Printable(name) + "' cannot be written (" +
                      (errno == EEXIST ? std::string("a duplicate name") : std::strerror(errno)) +
                      ")");
    for (;;) {
      const la_ssize_t n = archive_read_data(a.get(), buf.data(), buf.size());
      if (n == 0) break;
      if (n < 0) {
        ::close(fd);
        return fail(ArchiveProblem::kMalformed,
                    "archive entry '" + Printable(name) + "' is corrupt: " + ArchiveError(a.get()));
      }
      result.bytes += n;
      if (result.bytes > budget) {
        ::close(fd);
        return fail(ArchiveProblem::kLimit, over_budget);
      }
      for (la_ssize_t off = 0; off < n;) {
        const ssize_t w = ::write(fd, buf.data() + off, size_t(n - off));
        if (w <= 0) {
          const int err = w < 0 ? errno : ENOSPC;  // a write of 0 bytes: the disk is full
          ::close(fd);
          if (IsNoSpace(err)) return no_space(name);
          return fail(ArchiveProblem::kNone, "writing archive entry '" + Printable(name) +
                                                 "' failed: " + std::strerror(err));
        }
        off += w;
      }
    }
    if (::close(fd) != 0) {
      const int err = errno;
      if (IsNoSpace(err)) return no_space(name);
      return fail(ArchiveProblem::kNone,
                  "writing archive entry '" + Printable(name) + "' failed: " + std::strerror(err));
    }
  }
  // One top-level folder and nothing else: that folder is the dataset.
  std::vector<fs::path> top;
  for (const auto& d : fs::directory_iterator(dest, ec)) top.push_back(d.path());
  if (top.empty()) return fail(ArchiveProblem::kMalformed, "the archive contains no files");
  if (top.size() == 1 && fs::is_directory(top[0], ec)) result.dataset_root = top[0].string();
  keep = true;
  return result;
}

}  // namespace matfit::server
