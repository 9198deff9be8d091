// Path confinement: whether a file resolves (symlinks and `..` followed) inside a root folder.
// The server confines every file a job reads to the job's dataset folder.
#pragma once

#include <string>

#include "core/status.h"

namespace matfit {

// True when `path`, with symlinks and `..` resolved, is `root` or lies under it. A path that
// does not exist is judged by its existing prefix (std::filesystem::weakly_canonical).
bool PathWithin(const std::string& path, const std::string& root);

// The one gate every dataset reader opens a dataset-side file through (images, light files,
// masks, manifests, truth maps). With an empty `root` it returns `path` unchanged (the CLI reads
// what it is given). Otherwise it returns realpath(path), which must lie inside realpath(root):
// a file that resolves elsewhere (a symlink, `..`, an absolute name) is refused with
// kInvalidArgument, a missing one (or a link to nothing) is kNotFound. Messages name the file
// relative to `root` and never where a link leads, so nothing of the outside shows. The caller
// opens the returned path.
StatusOr<std::string> ResolveInDataset(const std::string& path, const std::string& root);

// `path` as messages show it: relative to `root` when it lies (by name) inside it, else as given.
std::string DatasetRelative(const std::string& path, const std::string& root);

}  // namespace matfit
