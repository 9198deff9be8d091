// Test helper: writes .zip / .tar / .tar.gz archives entry by entry (libarchive), including the
// hostile entries a server must refuse (`..`, absolute names, links).
#pragma once

#include <archive.h>
#include <archive_entry.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace matfit::server::testing {

class ArchiveWriter {
 public:
  enum class Format { kZip, kTar, kTarGz };
  ArchiveWriter(const std::string& path, Format f) : a_(archive_write_new()) {
    if (f == Format::kZip) archive_write_set_format_zip(a_);
    if (f != Format::kZip) archive_write_set_format_pax_restricted(a_);
    if (f == Format::kTarGz) archive_write_add_filter_gzip(a_);
    archive_write_open_filename(a_, path.c_str());
  }
  ~ArchiveWriter() { Close(); }
  void Close() {
    if (!a_) return;
    archive_write_close(a_);
    archive_write_free(a_);
    a_ = nullptr;
  }
  void File(const std::string& name, const std::string& data) {
    archive_entry* e = archive_entry_new();
    archive_entry_set_pathname(e, name.c_str());
    archive_entry_set_size(e, la_int64_t(data.size()));
    archive_entry_set_filetype(e, AE_IFREG);
    archive_entry_set_perm(e, 0644);
    archive_write_header(a_, e);
    archive_write_data(a_, data.data(), data.size());
    archive_entry_free(e);
  }
  // `size` zero bytes written in chunks (a zip bomb compresses this ~1000×).
  void Zeros(const std::string& name, int64_t size) {
    archive_entry* e = archive_entry_new();
    archive_entry_set_pathname(e, name.c_str());
    archive_entry_set_size(e, size);
    archive_entry_set_filetype(e, AE_IFREG);
    archive_entry_set_perm(e, 0644);
    archive_write_header(a_, e);
    const std::string chunk(1 << 20, '\0');
    for (int64_t left = size; left > 0; left -= int64_t(chunk.size()))
      archive_write_data(a_, chunk.data(), size_t(std::min<int64_t>(left, chunk.size())));
    archive_entry_free(e);
  }
  void Symlink(const std::string& name, const std::string& target) {
    archive_entry* e = archive_entry_new();
    archive_entry_set_pathname(e, name.c_str());
    archive_entry_set_filetype(e, AE_IFLNK);
    archive_entry_set_symlink(e, target.c_str());
    archive_entry_set_perm(e, 0777);
    archive_write_header(a_, e);
    archive_entry_free(e);
  }
  void Hardlink(const std::string& name, const std::string& target) {
    archive_entry* e = archive_entry_new();
    archive_entry_set_pathname(e, name.c_str());
    archive_entry_set_filetype(e, AE_IFREG);
    archive_entry_set_hardlink(e, target.c_str());
    archive_entry_set_size(e, 0);
    archive_write_header(a_, e);
    archive_entry_free(e);
  }
  // Every file under `dir`, named `prefix/relative/path`, except the file named `skip`.
  void Folder(const std::string& dir, const std::string& prefix, const std::string& skip = "") {
    namespace fs = std::filesystem;
    for (const auto& f : fs::recursive_directory_iterator(dir)) {
      if (!f.is_regular_file() || f.path().filename() == skip) continue;
      std::ifstream in(f.path(), std::ios::binary);
      std::stringstream s;
      s << in.rdbuf();
      File(prefix + "/" + fs::relative(f.path(), dir).string(), s.str());
    }
  }

 private:
  struct archive* a_;
};

}  // namespace matfit::server::testing
