#include "server/preview.h"

#include <future>

#include "core/image_io.h"
#include "core/pack/pack_reader.h"
#include "render/cpu_renderer.h"
#include "render/egl_renderer.h"

namespace matfit::server {

PreviewRenderer::PreviewRenderer(std::string backend)
    : backend_(std::move(backend)), thread_([this] { Loop(); }) {}

PreviewRenderer::~PreviewRenderer() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void PreviewRenderer::Loop() {
  std::unique_ptr<render::EglRenderer> egl;
  bool tried = false;
  for (;;) {
    std::function<void(render::EglRenderer*)> task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return stop_ || !tasks_.empty(); });
      if (stop_ && tasks_.empty()) return;
      task = std::move(tasks_.front());
      tasks_.pop_front();
    }
    if (!tried) {  // created lazily on this thread, which keeps its context current
      tried = true;
      std::string description = "the CPU reference renderer";
      if (backend_ != "cpu") {
        auto r = render::EglRenderer::Create();
        if (r.ok()) {
          egl = std::move(*r);
          description = egl->Description();
        } else {
          description += " (" + r.status().message() + ")";
        }
      }
      std::lock_guard<std::mutex> lock(mutex_);
      description_ = description;
    }
    task(egl.get());
  }
}

StatusOr<std::string> PreviewRenderer::Render(const std::string& pack_dir,
                                              const render::RenderOptions& o) {
  std::promise<StatusOr<std::string>> done;
  auto result = done.get_future();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    tasks_.push_back([&](render::EglRenderer* egl) {
      auto pack = ReadPack(pack_dir);
      if (!pack.ok()) return done.set_value(pack.status());
      auto img = egl ? egl->Render(pack->maps, o) : render::RenderCpu(pack->maps, o);
      if (!img.ok()) return done.set_value(img.status());
      ImageWriteOptions wo;
      wo.format = PixelFormat::kUint8;
      wo.transfer = TransferFunction::kLinear;  // display output is already sRGB-encoded
      done.set_value(EncodeImage(*img, "png", wo));
    });
  }
  cv_.notify_one();
  return result.get();
}

std::string PreviewRenderer::Description() {
  std::lock_guard<std::mutex> lock(mutex_);
  return description_.empty() ? "not started" : description_;
}

}  // namespace matfit::server
