// What matfit wrote, so that --force replaces only that. Every folder matfit writes as a
// whole (pack, dataset, leaf scan, bench report) carries a marker file that lists its files;
// every image it writes says "matfit" in its Software tag; a zipped pack holds the marker.
#pragma once

#include <string>

#include "core/status.h"

namespace matfit {

inline constexpr char kOutputMarkerName[] = ".matfit-output.json";
// Last line of the light files matfit writes (.lp, lights.txt): a comment the readers skip.
inline constexpr char kTextOutputTrailer[] = "# written by matfit";

// Writes the marker into folder `dir`: {"schema": "matfit.output/1", "kind": kind,
// "version": ..., "files": [every regular file under dir, relative, sorted]}.
Status WriteOutputMarker(const std::string& dir, const std::string& kind);

// Ok when `path` does not exist or holds only what matfit wrote: a marked folder with no file
// the marker does not list, a zip with the marker entry, an image whose Software tag starts
// with "matfit", a JSON report with "generator": "matfit …", or a light file (.lp, .txt)
// ending in kTextOutputTrailer. Otherwise InvalidArgument naming the path, why it is not matfit's,
// and what to do. `what` names the option in messages ("--out").
Status CheckReplaceable(const std::string& path, const std::string& what = "--out");

// The check every writer makes before it starts: Ok when `path` does not exist; when it does,
// an error unless `force` (then CheckReplaceable).
Status CheckOutput(const std::string& path, bool force, const std::string& what = "--out");

}  // namespace matfit
