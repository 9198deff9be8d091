#include "core/output_marker.h"

#include <zip.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "core/atomic_file.h"
#include "core/image_codec.h"
#include "core/version.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

Status Refuse(const std::string& path, const std::string& why, const std::string& what) {
  return InvalidArgument("'" + path + "' " + why +
                         "; --force only replaces what matfit wrote. Choose another " + what +
                         " or move it away yourself");
}

bool ZipHasMarker(const std::string& path) {
  int err = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z) return false;
  const bool found = zip_name_locate(z, kOutputMarkerName, 0) >= 0;
  zip_close(z);
  return found;
}

bool ImageIsMatfits(const std::string& path) {
  std::string error;
  auto in = codec::OpenAny(path, &error);
  if (in && !in->header().software_known) {  // a native reader that skips the tag (JPEG)
    codec::Backend* oiio = codec::OpenImageIo(&error);
    in = oiio ? oiio->Open(path, &error) : nullptr;
  }
  return in && in->header().software.rfind("matfit", 0) == 0;
}

// A JSON report matfit wrote: {"generator": "matfit ...", ...}.
bool JsonIsMatfits(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const json j = json::parse(in, nullptr, false);
  return j.is_object() && j.contains("generator") && j["generator"].is_string() &&
         j["generator"].get<std::string>().rfind("matfit", 0) == 0;
}

// A light file matfit wrote: its last non-blank line starts with kTextOutputTrailer.
bool TextIsMatfits(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line, last;
  for (int n = 0; std::getline(in, line) && n < 1'000'000; ++n)
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  return last.rfind(kTextOutputTrailer, 0) == 0;
}

Status CheckFolder(const std::string& path, const std::string& what) {
  const fs::path marker = fs::path(path) / kOutputMarkerName;
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(marker, ec)))
    return Refuse(
        path, std::string("was not written by matfit (it has no ") + kOutputMarkerName + ")", what);
  std::ifstream in(marker);
  const json m = json::parse(in, nullptr, false);
  if (!m.is_object() || !m.contains("schema") || m["schema"] != "matfit.output/1" ||
      !m.contains("files") || !m["files"].is_array())
    return Refuse(path, std::string("has an unreadable ") + kOutputMarkerName, what);
  std::set<std::string> listed;
  for (const json& f : m["files"])
    if (f.is_string()) listed.insert(f.get<std::string>());
  // Anything not listed was put there by someone else: refuse rather than delete it.
  for (auto it = fs::recursive_directory_iterator(path, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    const fs::file_status st = it->symlink_status(ec);
    if (fs::is_directory(st)) continue;
    const std::string rel = fs::relative(it->path(), path, ec).generic_string();
    if (rel == kOutputMarkerName) continue;
    if (!fs::is_regular_file(st) || !listed.count(rel))
      return Refuse(path, "holds '" + rel + "', which matfit did not write there", what);
  }
  if (ec) return IoError("cannot list '" + path + "': " + ec.message());
  return Status::Ok();
}

}  // namespace

Status WriteOutputMarker(const std::string& dir, const std::string& kind) {
  std::vector<std::string> files;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const std::string rel = fs::relative(it->path(), dir, ec).generic_string();
    if (rel != kOutputMarkerName) files.push_back(rel);
  }
  if (ec) return IoError("cannot list '" + dir + "': " + ec.message());
  std::sort(files.begin(), files.end());
  const json m = {{"schema", "matfit.output/1"},
                  {"kind", kind},
                  {"version", std::string("matfit ") + kMatfitVersion},
                  {"files", files}};
  return WriteFileAtomic((fs::path(dir) / kOutputMarkerName).string(),
                         m.dump(2, ' ', false, json::error_handler_t::replace) + "\n");
}

Status CheckReplaceable(const std::string& path, const std::string& what) {
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(path, ec);
  if (ec || !fs::exists(st)) return Status::Ok();
  if (fs::is_symlink(st)) return Refuse(path, "is a symbolic link", what);
  if (fs::is_directory(st)) return CheckFolder(path, what);
  if (!fs::is_regular_file(st)) return Refuse(path, "is not a regular file or folder", what);
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == ".zip") {
    if (ZipHasMarker(path)) return Status::Ok();
    return Refuse(path, std::string("is not a zip matfit wrote (no ") + kOutputMarkerName + ")",
                  what);
  }
  if (ext == ".json") {
    if (JsonIsMatfits(path)) return Status::Ok();
    return Refuse(path, "is not a report matfit wrote (no \"generator\": \"matfit …\")", what);
  }
  if (ext == ".lp" || ext == ".txt") {
    if (TextIsMatfits(path)) return Status::Ok();
    return Refuse(path,
                  std::string("is not a light file matfit wrote (no '") + kTextOutputTrailer +
                      "' line at its end)",
                  what);
  }
  if (ImageIsMatfits(path)) return Status::Ok();
  return Refuse(path, "is not a file matfit wrote (no \"matfit\" Software tag)", what);
}

Status CheckOutput(const std::string& path, bool force, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(path, ec))) return Status::Ok();
  if (!force)
    return InvalidArgument("output '" + path + "' already exists; choose another " + what +
                           " or pass --force to replace it");
  return CheckReplaceable(path, what);
}

}  // namespace matfit
