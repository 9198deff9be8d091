// Path confinement: whether a file resolves (symlinks and `..` followed) inside a root folder.
// The server confines every file a job reads to the job's dataset folder.
#pragma once

#include <string>

namespace matfit {

// True when `path`, with symlinks and `..` resolved, is `root` or lies under it. A path that
// does not exist is judged by its existing prefix (std::filesystem::weakly_canonical).
bool PathWithin(const std::string& path, const std::string& root);

}  // namespace matfit
