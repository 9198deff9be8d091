#include "server/preview.h"

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <thread>

#include "core/image_io.h"
#include "core/pack/pack_reader.h"
#include "render/cpu_renderer.h"
#include "render/egl_renderer.h"

namespace matfit::server {

// One render thread and its queue. Each task gets the lane's EGL renderer (nullptr: use the
// CPU one), created lazily on the lane's thread, which keeps its context current.
struct PreviewRenderer::Lane {
  explicit Lane(std::string lane_name, std::string backend_name)
      : name(std::move(lane_name)), backend(std::move(backend_name)), thread([this] { Loop(); }) {}
  ~Lane() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
    }
    cv.notify_all();
    thread.join();
  }
  void Loop();

  const std::string name, backend;
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<std::function<void(render::EglRenderer*)>> tasks;
  int waiting = 0;  // tasks not yet started
  bool stop = false;
  std::string description;
  std::thread thread;  // last: it starts running Loop
};

void PreviewRenderer::Lane::Loop() {
  std::unique_ptr<render::EglRenderer> egl;
  bool tried = false;
  for (;;) {
    std::function<void(render::EglRenderer*)> task;
    {
      std::unique_lock<std::mutex> lock(mutex);
      cv.wait(lock, [&] { return stop || !tasks.empty(); });
      if (stop && tasks.empty()) return;
      task = std::move(tasks.front());
      tasks.pop_front();
      --waiting;
    }
    if (!tried) {
      tried = true;
      std::string d = "the CPU reference renderer";
      if (backend != "cpu") {
        static std::mutex create_mutex;  // one EGL initialisation at a time
        std::lock_guard<std::mutex> lock(create_mutex);
        auto r = render::EglRenderer::Create();
        if (r.ok()) {
          egl = std::move(*r);
          d = egl->Description();
        } else {
          d += " (" + r.status().message() + ")";
        }
      }
      std::lock_guard<std::mutex> lock(mutex);
      description = d;
    }
    task(egl.get());
  }
}

PreviewRenderer::PreviewRenderer(const PreviewOptions& options)
    : options_(options),
      small_(std::make_unique<Lane>("small", options.backend)),
      large_(std::make_unique<Lane>("large", options.backend)) {}

PreviewRenderer::~PreviewRenderer() = default;

StatusOr<std::string> PreviewRenderer::Render(const std::string& pack_dir,
                                              const render::RenderOptions& o) {
  Lane& lane = int64_t(o.size) * o.size <= options_.small_max_pixels ? *small_ : *large_;
  std::promise<StatusOr<std::string>> done;
  auto result = done.get_future();
  {
    std::lock_guard<std::mutex> lock(lane.mutex);
    if (lane.waiting >= options_.max_queued)
      return Status(StatusCode::kUnavailable,
                    "the server is busy: " + std::to_string(lane.waiting) + " " + lane.name +
                        " previews are waiting to render; retry shortly");
    ++lane.waiting;
    lane.tasks.push_back([&](render::EglRenderer* egl) {
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
  lane.cv.notify_one();
  return result.get();
}

std::string PreviewRenderer::Description() {
  for (Lane* lane : {small_.get(), large_.get()}) {
    std::lock_guard<std::mutex> lock(lane->mutex);
    if (!lane->description.empty()) return lane->description;
  }
  return "not started";
}

}  // namespace matfit::server
