#include "core/path_util.h"

#include <climits>
#include <cstdlib>
#include <filesystem>
#include <memory>

namespace matfit {
namespace {

namespace fs = std::filesystem;

// realpath(3), or empty with errno set.
std::string RealPath(const std::string& path) {
  std::unique_ptr<char, decltype(&std::free)> r(::realpath(path.c_str(), nullptr), &std::free);
  return r ? std::string(r.get()) : std::string();
}

// `p` is `root` or below it, component-wise; both are absolute and resolved (a trailing '/' on
// the root is ignored).
bool Under(const std::string& p, std::string root) {
  while (root.size() > 1 && root.back() == '/') root.pop_back();
  if (root == "/") return true;
  return p == root ||
         (p.size() > root.size() && p.compare(0, root.size(), root) == 0 && p[root.size()] == '/');
}

}  // namespace

bool PathWithin(const std::string& path, const std::string& root) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) return false;
  const fs::path r = fs::weakly_canonical(fs::absolute(root, ec), ec);
  if (ec) return false;
  return Under(p.string(), r.string());
}

std::string DatasetRelative(const std::string& path, const std::string& root) {
  if (root.empty()) return path;
  std::error_code ec;
  const fs::path p = fs::absolute(path, ec).lexically_normal();
  const fs::path r = fs::absolute(root, ec).lexically_normal();
  const fs::path rel = p.lexically_relative(r);
  if (rel.empty() || *rel.begin() == "..") return path;
  return rel.string();
}

StatusOr<std::string> ResolveInDataset(const std::string& path, const std::string& root) {
  if (root.empty()) return path;
  const std::string shown = DatasetRelative(path, root);
  const std::string real_root = RealPath(root);
  if (real_root.empty()) return NotFound("the dataset folder no longer exists");
  const std::string real = RealPath(path);
  if (real.empty()) {
    std::error_code ec;
    if (fs::is_symlink(path, ec))
      return NotFound("'" + shown + "' is a link to a file that does not exist");
    return NotFound("file '" + shown + "' does not exist");
  }
  if (!Under(real, real_root))
    return InvalidArgument("'" + shown +
                           "' lies outside the dataset folder (a link, '..' or an absolute "
                           "name leads out of it) and is not read; put the file itself inside "
                           "the dataset folder");
  return real;
}

}  // namespace matfit
