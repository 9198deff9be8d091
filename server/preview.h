// Server-side previews: one render thread owns the EGL renderer (a GL context belongs to one
// thread), falling back to the CPU reference renderer when EGL is unavailable. Renders come
// back as PNG bytes; the server caches them (server/preview_cache.h).
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "core/status.h"
#include "render/render_options.h"

namespace matfit::render {
class EglRenderer;
}

namespace matfit::server {

class PreviewRenderer {
 public:
  // backend: "auto" (EGL, else CPU), "egl" or "cpu".
  explicit PreviewRenderer(std::string backend = "auto");
  ~PreviewRenderer();
  PreviewRenderer(const PreviewRenderer&) = delete;
  PreviewRenderer& operator=(const PreviewRenderer&) = delete;

  // Pack `pack_dir` rendered with `o`, as a PNG file's bytes; blocks until done.
  StatusOr<std::string> Render(const std::string& pack_dir, const render::RenderOptions& o);
  std::string Description();  // which backend renders

 private:
  void Loop();
  std::string backend_;
  std::mutex mutex_;
  std::condition_variable cv_;
  // Each task gets the EGL renderer (nullptr: use the CPU one).
  std::deque<std::function<void(render::EglRenderer*)>> tasks_;
  bool stop_ = false;
  std::string description_;
  std::thread thread_;
};

}  // namespace matfit::server
