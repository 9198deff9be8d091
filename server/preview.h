// Server-side previews. Renders run on two lanes, each a thread that owns its own EGL renderer
// (a GL context belongs to one thread), falling back to the CPU reference renderer when EGL is
// unavailable: small previews (the viewer's and the default 256²) never wait behind large ones.
// Each lane queues a bounded number of renders. Renders come back as PNG bytes; the server
// caches them (server/preview_cache.h).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/status.h"
#include "render/render_options.h"

namespace matfit::server {

struct PreviewOptions {
  std::string backend = "auto";          // "auto" (EGL, else CPU), "egl" or "cpu"
  int64_t small_max_pixels = 256 * 256;  // renders up to this many pixels take the small lane
  int max_queued = 8;                    // per lane: renders waiting beyond this are refused
};

class PreviewRenderer {
 public:
  explicit PreviewRenderer(const PreviewOptions& options = {});
  ~PreviewRenderer();
  PreviewRenderer(const PreviewRenderer&) = delete;
  PreviewRenderer& operator=(const PreviewRenderer&) = delete;

  // Pack `pack_dir` rendered with `o`, as a PNG file's bytes; blocks until done. kUnavailable
  // when the lane already has max_queued renders waiting.
  StatusOr<std::string> Render(const std::string& pack_dir, const render::RenderOptions& o);
  std::string Description();  // which backend renders

 private:
  struct Lane;
  PreviewOptions options_;
  std::unique_ptr<Lane> small_, large_;
};

}  // namespace matfit::server
