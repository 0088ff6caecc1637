#include "service/render_thread.h"

#include <memory>

#include "render/renderer.h"

namespace myriad::service {

RenderThread::RenderThread(const gpu::ContextOptions& options, const scene::Scene& scene,
                           uint32_t maxQueuedFrames)
    : maxQueuedFrames_(maxQueuedFrames) {
  std::promise<void> ready;
  std::future<void> started = ready.get_future();
  thread_ = std::thread([this, &options, &scene, &ready] { run(options, scene, ready); });
  try {
    started.get();
  } catch (...) {
    // run() returns right after reporting a start-up failure.
    thread_.join();
    throw;
  }
}

RenderThread::~RenderThread() {
  stop();
}

uint32_t RenderThread::validationMessages() const {
  return validationCounter_ != nullptr ? validationCounter_->load() : 0;
}

std::future<render::Frame> RenderThread::submit(const render::FrameSettings& settings) {
  std::future<render::Frame> frame;
  {
    std::lock_guard lock(mutex_);
    if (stopping_) throw RenderQueueFullError("the server is shutting down");
    // The frame being rendered is not waiting; while none is, a new job starts at once.
    size_t ahead = jobs_.size() + (rendering_ ? 1 : 0);
    if (ahead > maxQueuedFrames_) {
      throw RenderQueueFullError(std::to_string(jobs_.size()) +
                                 " frames are already waiting for the renderer (the limit is " +
                                 std::to_string(maxQueuedFrames_) + ")");
    }
    Job& job = jobs_.emplace_back(Job{settings, {}});
    frame = job.result.get_future();
  }
  wake_.notify_one();
  return frame;
}

void RenderThread::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
  validationCounter_ = nullptr;
}

void RenderThread::run(const gpu::ContextOptions& options, const scene::Scene& scene,
                       std::promise<void>& ready) {
  std::unique_ptr<gpu::Context> context;
  std::unique_ptr<render::Renderer> renderer;
  try {
    context = gpu::createContext(options);
    renderer = std::make_unique<render::Renderer>(*context);
    renderer->setScene(scene);
    device_ = context->info;
    maxDimension_ = renderer->maxDimension();
    validationCounter_ = &context->validationMessages;
  } catch (...) {
    // Destroy in dependency order here, on this thread, before the constructor rethrows.
    renderer.reset();
    context.reset();
    ready.set_exception(std::current_exception());
    return;
  }
  // After this the constructor returns and `options`, `scene` and `ready` are gone.
  ready.set_value();

  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      // Stopping still renders what was queued: those requests are in flight and get answers.
      if (jobs_.empty()) break;
      job = std::move(jobs_.front());
      jobs_.pop_front();
      rendering_ = true;
    }
    try {
      job.result.set_value(renderer->render(job.settings));
    } catch (...) {
      job.result.set_exception(std::current_exception());
    }
    std::lock_guard lock(mutex_);
    rendering_ = false;
  }

  renderer.reset();
  context.reset();
}

}  // namespace myriad::service
